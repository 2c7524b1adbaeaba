#!/usr/bin/env python3
"""Marks the public API of include/mlspaces/**.h with MLSPACES_API (core/export.h):
classes and structs defined at namespace scope, and function declarations there (not inline,
not templates). Idempotent. Usage: add_api.py HEADER..."""
import re, sys

SKIP = ('//', '#', 'static_assert', 'return ', 'friend', 'using ', 'template', 'inline ', 'constexpr ', 'static ', 'extern ', 'enum ',
        'namespace', '}', 'friend ', 'typedef ', 'MLSPACES_API', 'class ', 'struct ', 'union ')

def process(path):
    src = open(path).read().split('\n')
    out = []
    stack = []            # 'ns' or 'x' per open brace
    prev = ''             # previous non-blank, non-comment line at namespace scope
    i = 0
    changed = False
    in_block_comment = False
    while i < len(src):
        line = src[i]
        s = line.strip()
        at_ns = all(t == 'ns' for t in stack) and any(t == 'ns' for t in stack)
        if at_ns and not in_block_comment and line and not line[0].isspace():
            m = re.match(r'^(class|struct) (?!MLSPACES_API)(\w+)(\s+final)?\s*(:|\{|$)', line)
            if m and not prev.startswith('template') and not line.rstrip().endswith(';'):
                line = line.replace(m.group(1) + ' ', m.group(1) + ' MLSPACES_API ', 1)
                changed = True
            elif not s.startswith(SKIP) and not re.match(r'^\[\[[^\]]*\]\]\s*(inline|constexpr|template|static)', s) \
                    and not prev.startswith('template'):
                # accumulate the statement to see how it ends
                j, stmt = i, ''
                while j < len(src):
                    stmt += ' ' + re.sub(r'//.*', '', src[j])
                    if ';' in stmt or '{' in stmt:
                        break
                    j += 1
                body = stmt.strip()
                is_decl = '(' in body and ';' in body and ('{' not in body or body.index(';') < body.index('{')) \
                    and '=' not in body.split('(')[0]
                if is_decl:
                    m2 = re.match(r'^(\[\[[^\]]*\]\]\s*)(.*)$', line)
                    line = (m2.group(1) + 'MLSPACES_API ' + m2.group(2)) if m2 else 'MLSPACES_API ' + line
                    changed = True
        if s.startswith('/*'):
            in_block_comment = '*/' not in s
        elif in_block_comment and '*/' in s:
            in_block_comment = False
        code = re.sub(r'//.*', '', line)
        code = re.sub(r'"(\\.|[^"\\])*"', '""', code)
        code = re.sub(r"'(\\.|[^'\\])*'", "''", code)
        for ch in code:
            if ch == '{':
                stack.append('ns' if re.match(r'^\s*(inline\s+)?namespace\b', code) and '=' not in code else 'x')
            elif ch == '}':
                if stack: stack.pop()
        if s and not s.startswith('//'):
            prev = s
        out.append(line)
        i += 1
    text = '\n'.join(out)
    if changed and '#include "mlspaces/core/export.h"' not in text:
        # after #pragma once
        text = text.replace('#pragma once\n', '#pragma once\n\n#include "mlspaces/core/export.h"\n', 1)
    if text != '\n'.join(src):
        open(path, 'w').write(text)
        return True
    return False

for p in sys.argv[1:]:
    if p.endswith('core/export.h'):
        continue
    process(p)
