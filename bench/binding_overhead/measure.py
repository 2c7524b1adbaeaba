"""Median ns per call of the same bound calls through nanobind and pybind11."""
import statistics
import sys
import timeit

sys.path.insert(0, sys.argv[1])
import nb_lookup  # noqa: E402
import pb_lookup  # noqa: E402


def ns(stmt, glb, number=200000, rounds=9):
    return statistics.median(t / number * 1e9 for t in
                             timeit.repeat(stmt, globals=glb, number=number, repeat=rounds))


print(f"{'call':<22}{'nanobind ns':>12}{'pybind11 ns':>12}{'ratio':>8}")
for name, stmt in (("noop()", "m.noop()"), ("locate(str)->tuple", "t.locate('uid_500')"),
                   ("annotation->dict", "t.annotation('uid_500')")):
    a = ns(stmt, {"m": nb_lookup, "t": nb_lookup.Table()})
    b = ns(stmt, {"m": pb_lookup, "t": pb_lookup.Table()})
    print(f"{name:<22}{a:>12.1f}{b:>12.1f}{b / a:>8.2f}")
