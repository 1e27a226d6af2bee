"""The hard-case suite: each case states its bound and records what it measured.

`hard_case(name, value, bound)` asserts value <= bound (and that both are finite) and
keeps the pair; with LANTERN_HARD_CASES=path set, the session writes every recorded
case as a markdown table there (the hard-case tables of docs/status.md come from it).
"""
import math
import os

import pytest

_RECORDED = []


@pytest.fixture
def hard_case(request):
    family = request.module.__name__.rpartition(".")[2].removeprefix("test_")

    def check(name, value, bound, unit="", lower=False):
        value = float(value)
        assert math.isfinite(value), f"{name}: measured {value}"
        _RECORDED.append((family, name, bound, value, unit, lower))
        if lower:
            assert value >= bound, f"{name}: {value:.3g} {unit} below the bound {bound:g}"
        else:
            assert value <= bound, f"{name}: {value:.3g} {unit} above the bound {bound:g}"
        return value

    def record(name, value, unit=""):
        """A figure worth the table that is not asserted (a timing)."""
        _RECORDED.append((family, name, None, float(value), unit, False))
    check.record = record
    return check


def pytest_sessionfinish(session):
    path = os.environ.get("LANTERN_HARD_CASES")
    if not path or not _RECORDED:
        return
    lines = ["| family | case | bound | measured |", "|---|---|---|---|"]
    for family, name, bound, value, unit, lower in sorted(_RECORDED, key=lambda r: r[:2]):
        sign = "≥" if lower else "≤"
        limit = "(figure)" if bound is None else f"{sign} {bound:g} {unit}"
        lines.append(f"| {family} | {name} | {limit} | {value:.3g} {unit} |")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
