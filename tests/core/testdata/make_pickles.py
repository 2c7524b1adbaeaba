"""Writes the pickles tests/core/pickle_test.cc decodes: OUT/<case>.pkl beside OUT/<case>.expect.

An .expect file holds either the value's canonical description (describe() below, which the
test renders the same way from the decoded tree) or "ERROR: <substring of the message>" for a
pickle the restricted reader must refuse. Usage: make_pickles.py OUT
"""

import os
import pickle
import struct
import sys

import numpy as np


def describe(v):
    """One canonical line per value; pickle_test.cc's Describe() must give the same."""
    if v is None:
        return "None"
    if isinstance(v, (bool, np.bool_)) and not isinstance(v, np.ndarray) and type(v) is bool:
        return "True" if v else "False"
    if isinstance(v, np.ndarray) or isinstance(v, np.generic):
        a = np.asarray(v)
        fortran = int(a.ndim > 1 and a.flags.f_contiguous and not a.flags.c_contiguous)
        le = np.ascontiguousarray(a).astype(a.dtype.newbyteorder("<"))
        kind = "np" if isinstance(v, np.generic) else "nd"
        shape = ",".join(str(d) for d in a.shape)
        return f"{kind}({a.dtype.kind}{a.dtype.itemsize};{shape};{fortran};{le.tobytes().hex()})"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "f:" + struct.pack(">d", v).hex()
    if isinstance(v, str):
        return "s:" + v.encode("utf-8").hex()
    if isinstance(v, bytearray):
        return "ba:" + bytes(v).hex()
    if isinstance(v, bytes):
        return "b:" + v.hex()
    if isinstance(v, list):
        return "[" + ",".join(describe(x) for x in v) + "]"
    if isinstance(v, tuple):
        return "(" + ",".join(describe(x) for x in v) + ")"
    if isinstance(v, dict):
        return "{" + ",".join(describe(k) + ":" + describe(x) for k, x in v.items()) + "}"
    raise TypeError(type(v))


class Gadget:
    """The classic: unpickling calls os.system."""

    def __reduce__(self):
        return (os.system, ("echo pwned",))


class EvalGadget:
    def __reduce__(self):
        import builtins
        return (builtins.eval, ("1+1",))


class Plain:
    pass


def values():
    rng = np.random.default_rng(7)
    shared = [1, 2]
    return {
        "none": None,
        "bools": [True, False],
        "ints": [0, 1, -1, 255, 256, 65535, 65536, -129, 2**31 - 1, -(2**31), 2**40, -(2**40),
                 2**63 - 1, -(2**63)],
        "floats": [0.0, -0.0, 1.5, -2.25e-300, 1e308, float("inf"), float("-inf")],
        "unicode": ["", "ascii", "héllo wörld", "日本語", "emoji \U0001F600", "x" * 300],
        "bytes": [b"", b"\x00\xff\x80abc", bytes(range(256)), b"y" * 70000],
        "bytearray": bytearray(b"\x01\x02\x03"),
        "nested": {"a": [1, (2, 3), {"b": {"c": [[], (), {}]}}], "t": ((1,), (2, (3, None)))},
        "dict_keys": {1: "int", (1, "two"): "tuple", None: "none", b"k": "bytes", 2.5: "float"},
        "shared": [shared, shared, {"again": shared}],
        "f16": np.arange(-4, 4, dtype=np.float16) / 3,
        "f32": rng.standard_normal((3, 4)).astype(np.float32),
        "f64": rng.standard_normal((2, 3, 4)),
        "i32": np.arange(12, dtype=np.int32).reshape(3, 4) - 6,
        "i64": np.array([-(2**63), 2**63 - 1, 0], dtype=np.int64),
        "u8": np.arange(250, 256, dtype=np.uint8),
        "bool_array": np.array([[True, False], [False, True]]),
        "zero_d": np.array(3.25),
        "empty": np.zeros((0, 3), dtype=np.float32),
        "fortran": np.asfortranarray(np.arange(24, dtype=np.float64).reshape(2, 3, 4)),
        "fortran_f16": np.asfortranarray(rng.standard_normal((3, 5)).astype(np.float16)),
        "big_endian": np.arange(6, dtype=">f4").reshape(2, 3),
        "big_endian_i8": np.array([1, -2, 3], dtype=">i8"),
        "scalars": [np.float32(1.5), np.float64(-2.5), np.float16(0.333), np.int64(-7),
                    np.int32(9), np.uint8(200), np.bool_(True)],
        "annotation": {
            "uid": "0a1b2c", "category": "Mug", "description_short": {"0": "a mug", "1": "cup"},
            "isObjaverse": True, "scale": 0.25, "license_info": {"license": "by", "uri": None},
            "clip_img_features": rng.standard_normal((3, 768)).astype(np.float16),
            "clip_text_features": rng.standard_normal(768).astype(np.float16),
        },
        "array_in_list": [np.ones(2, dtype=np.float32), [np.zeros((1, 1))]],
    }


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)

    def write(name, data, expect):
        with open(os.path.join(out, name + ".pkl"), "wb") as f:
            f.write(data)
        with open(os.path.join(out, name + ".expect"), "w") as f:
            f.write(expect)

    for name, value in values().items():
        for proto in (2, 3, 4, 5):
            data = pickle.dumps(value, protocol=proto)
            write(f"{name}_p{proto}", data, describe(value))
            assert describe(pickle.loads(data)) == describe(value), name
            # numpy 1.x names its modules numpy.core.*: the same pickle as 1.x writes it.
            # (GLOBAL lines have no length prefix, so the names can be swapped in place.)
            if b"numpy._core" in data and proto in (2, 3):
                old = data.replace(b"numpy._core", b"numpy.core")
                write(f"{name}_p{proto}_numpy1", old, describe(value))

    for proto in (2, 4, 5):
        builtins = "__builtin__" if proto < 3 else "builtins"  # protocol 2 writes 2.x names
        write(f"os_system_p{proto}", pickle.dumps(Gadget(), protocol=proto),
              "ERROR: global posix.system is not allowed")
        write(f"eval_p{proto}", pickle.dumps(EvalGadget(), protocol=proto),
              f"ERROR: global {builtins}.eval is not allowed")
        write(f"object_p{proto}", pickle.dumps(Plain(), protocol=proto),
              "ERROR: global __main__.Plain is not allowed")
        write(f"set_p{proto}", pickle.dumps({1, 2}, protocol=proto),
              f"ERROR: global {builtins}.set is not allowed" if proto < 4
              else "ERROR: sets are not supported")
        write(f"object_array_p{proto}", pickle.dumps(np.array([1, "a"], dtype=object),
                                                     protocol=proto),
              "ERROR: unsupported numpy dtype 'O8'")
        write(f"int16_p{proto}", pickle.dumps(np.zeros(2, dtype=np.int16), protocol=proto),
              "ERROR: unsupported numpy dtype 'i2'")
        write(f"huge_int_p{proto}", pickle.dumps(2**64, protocol=proto),
              "ERROR: integer larger than 64 bits")
    write("protocol1", pickle.dumps([1], protocol=1), "ERROR: not a protocol 2-5 pickle")


if __name__ == "__main__":
    main()
