// MLSPACES_API marks the declarations the mlspaces libraries export.
//
// Every layer is compiled with hidden visibility (-fvisibility=hidden,
// -fvisibility-inlines-hidden): built as shared libraries (-DBUILD_SHARED_LIBS=ON) only what a
// public header marks MLSPACES_API is visible to their users, and internal helpers stay out of
// the dynamic symbol table; built static (the default) the mark changes nothing. Public
// headers put it on classes and structs defined at namespace scope and on non-inline function
// declarations (scripts/dev/add_api.py adds it where a header lacks it).
#pragma once

#if defined(__GNUC__) || defined(__clang__)
#define MLSPACES_API __attribute__((visibility("default")))
#else
#define MLSPACES_API
#endif
