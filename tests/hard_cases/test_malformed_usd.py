"""Malformed USD: more than 100 damaged files (malformed_usd.py), each rendered by
`lantern render` with a watchdog. Every file ends in a clear one-line error (non-zero
exit) or renders with a warning, as its case expects; nothing ends in a traceback, a
hang, a crash, non-finite pixels or a silent black frame.

A case whose failure lies in engine/ is marked in ENGINE with the fix it needs
(strict: it fails the suite the moment the engine handles it, so the mark must go);
none is left."""
import pathlib

import pytest

from hard_cases import malformed_usd  # tests/ is on sys.path (conftest.py)

BAD = {"traceback", "hang", "crash", "nan", "black", "no-reason"}

# Every case that used to fail inside engine/ is handled there now: the
# table stays, empty, for the next engine-side case found.
ENGINE = {}

CASES = [(name, expect) for name, expect, _, _ in malformed_usd.cases()]


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory):
    folder = tmp_path_factory.mktemp("malformed")
    written = malformed_usd.generate(folder)
    results = malformed_usd.run([str(folder / f) for f in sorted(written)], folder / "_images")
    return {written[f][0]: results[str(folder / f)] for f in written}


def test_there_are_at_least_100_files_of_every_kind():
    assert len(CASES) >= 100
    assert len({name for name, _ in CASES}) == len(CASES)
    assert set(ENGINE) <= {name for name, _ in CASES}


def _params():
    for name, expect in CASES:
        marks = []
        if name in ENGINE:
            marks.append(pytest.mark.xfail(strict=True, raises=AssertionError,
                                           reason=ENGINE[name]))
        yield pytest.param(name, expect, marks=marks, id=name)


@pytest.mark.parametrize("name, expect", list(_params()))
def test_damaged_file(outcomes, name, expect):
    outcome, detail = outcomes[name]
    assert outcome not in BAD, f"{name}: {outcome} {detail}"
    assert outcome in malformed_usd.allowed(expect), \
        f"{name}: expected {expect}, got {outcome} ({detail})"


def test_the_harness_sees_tracebacks_hangs_and_black_frames(tmp_path):
    """Negative controls for the classifier itself."""
    import numpy as np
    from lantern.engine.image_io import write_image
    black = tmp_path / "black.exr"
    write_image(str(black), np.zeros((2, 2, 4), np.float32))
    assert malformed_usd._classify(0, "", black)[0] == "black"
    assert malformed_usd._classify(1, "Traceback (most recent call last):\nX\n", black)[0] == "traceback"
    assert malformed_usd._classify("hang", "", black)[0] == "hang"
    assert malformed_usd._classify(-11, "", black)[0] == "crash"
    assert malformed_usd._classify(1, "lantern render: f.usda: \n", black)[0] == "no-reason"
    nan = tmp_path / "nan.exr"
    write_image(str(nan), np.full((2, 2, 4), np.nan, np.float32))
    assert malformed_usd._classify(0, "warning: x\n", nan)[0] == "nan"
