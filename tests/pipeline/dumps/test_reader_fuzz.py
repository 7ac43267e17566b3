"""Property-based tests of the dump readers (hypothesis): any valid dump round-trips exactly, with
the compiled parser and the pandas fallback; any corruption of a valid dump either raises
DumpError naming the file and a line inside it, or (a cut exactly between snapshots, which no
reader can tell from a shorter dump) gives exactly the leading snapshots. Never another exception,
never different numbers.
"""
from __future__ import annotations

import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pipeline.dumps import reader as dumps
from pipeline.dumps import fastparse

PARSERS = ("compiled", "pandas")
FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@contextmanager
def parser(name: str) -> Iterator[None]:
    """Use the compiled parser or force the pandas fallback inside the block."""
    saved = fastparse._lib, fastparse._tried
    if name == "pandas":
        fastparse._lib, fastparse._tried = None, True
    else:
        assert fastparse.compiled(), "no C compiler: the compiled dump parser is not available"
    try:
        yield
    finally:
        fastparse._lib, fastparse._tried = saved


@dataclass
class Snapshot:
    step: int
    box: np.ndarray  # (3, 2)
    rows: np.ndarray  # (n, ncols)


@dataclass
class DumpCase:
    kind: str
    columns: list[str]
    snapshots: list[Snapshot]

    def text(self) -> str:
        """The dump as LIGGGHTS writes it; floats with repr(), which round-trips doubles."""
        item = "ATOMS" if self.kind == "atoms" else "ENTRIES"
        out = []
        for s in self.snapshots:
            out.append(f"ITEM: TIMESTEP\n{s.step}\nITEM: NUMBER OF {item}\n{len(s.rows)}\nITEM: BOX BOUNDS pp pp ff\n")
            out.extend(f"{float(lo)!r} {float(hi)!r}\n" for lo, hi in s.box)
            out.append(f"ITEM: {item} {' '.join(self.columns)} \n")
            out.extend(" ".join(repr(float(v)) for v in row) + "\n" for row in s.rows)
        return "".join(out)


finite = st.floats(allow_nan=False, allow_infinity=False, width=64)
names = st.lists(st.from_regex(r"[a-z][a-z0-9_]{0,6}", fullmatch=True), min_size=1, max_size=8, unique=True)


@st.composite
def dump_cases(draw: st.DrawFn) -> DumpCase:
    kind = draw(st.sampled_from(["atoms", "entries"]))
    columns = draw(names)
    steps = sorted(draw(st.sets(st.integers(0, 10**9), min_size=1, max_size=4)))
    snapshots = []
    for step in steps:
        n = draw(st.integers(0, 12))
        values = draw(st.lists(finite, min_size=n * len(columns), max_size=n * len(columns)))
        lo = draw(st.lists(finite, min_size=3, max_size=3))
        box = np.array([[a, a + 1.0] for a in lo])
        snapshots.append(Snapshot(step, box, np.array(values, dtype=float).reshape(n, len(columns))))
    return DumpCase(kind, columns, snapshots)


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One folder for the module (hypothesis cannot reuse function-scoped fixtures per example)."""
    return tmp_path_factory.mktemp("fuzz")


def write(folder: Path, text: str) -> Path:
    path = folder / "f.dump"
    path.write_text(text)
    return path


def assert_same(dump: dumps.Dump, case: DumpCase, n_snapshots: int | None = None) -> None:
    expected = case.snapshots[:n_snapshots]
    assert dump.kind == case.kind and list(dump.columns) == case.columns
    assert list(dump.timesteps) == [s.step for s in expected]
    assert list(dump.counts) == [len(s.rows) for s in expected]
    for k, s in enumerate(expected):
        np.testing.assert_array_equal(dump.rows(k), s.rows)
        np.testing.assert_array_equal(dump.boxes[k], s.box)


@pytest.mark.parametrize("which", PARSERS)
@FUZZ
@given(case=dump_cases(), threads=st.sampled_from([1, 3]))
def test_valid_dumps_round_trip_exactly(folder: Path, which: str, case: DumpCase, threads: int) -> None:
    path = write(folder, case.text())
    with parser(which):
        assert_same(dumps.read_dump(path, threads=threads), case)


# ------------------------------------------------------------------------------ corruptions
def _lines(text: str) -> list[str]:
    return text.split("\n")[:-1]  # the text ends with a newline


def _join(lines: list[str]) -> str:
    return "\n".join(lines) + "\n"


def _data_lines(case: DumpCase) -> list[int]:
    """0-based indices of the data rows in the text."""
    out, line = [], 0
    for s in case.snapshots:
        line += 9
        out.extend(range(line, line + len(s.rows)))
        line += len(s.rows)
    return out


def _count_lines(case: DumpCase) -> list[int]:
    out, line = [], 0
    for s in case.snapshots:
        out.append(line + 3)
        line += 9 + len(s.rows)
    return out


@st.composite
def corruptions(draw: st.DrawFn) -> tuple[DumpCase, str, str]:
    """A valid case, its corrupted text, and what was done (for the failure message)."""
    case = draw(dump_cases())
    text = case.text()
    lines = _lines(text)
    data = _data_lines(case)
    choices = ["cut", "count+1", "count-1", "header", "duplicate-step-line"]
    if data:
        choices += ["bad-token", "drop-token", "extra-token", "non-finite", "duplicate-row"]
    how = draw(st.sampled_from(choices))
    if how == "cut":
        # anywhere, including inside a number of the last line
        at = draw(st.integers(1, len(text) - 1))
        return case, text[:at], f"cut at byte {at}"
    if how in ("count+1", "count-1"):
        k = draw(st.sampled_from(_count_lines(case)))
        n = int(lines[k]) + (1 if how == "count+1" else -1)
        if n < 0:
            n = 1
        lines[k] = str(n)
        return case, _join(lines), f"{how} at line {k + 1}"
    if how == "header":
        k = draw(st.sampled_from([i for i, line in enumerate(lines) if line.startswith("ITEM:")]))
        lines[k] = lines[k].replace("ITEM:", draw(st.sampled_from(["ITEM;", "item:", "ITEMS:"])), 1)
        return case, _join(lines), f"header at line {k + 1}"
    if how == "duplicate-step-line":
        k = draw(st.sampled_from([i + 1 for i, line in enumerate(lines) if line == "ITEM: TIMESTEP"]))
        lines.insert(k, lines[k])
        return case, _join(lines), f"timestep line doubled at {k + 1}"
    k = draw(st.sampled_from(data))
    words = lines[k].split(" ")
    j = draw(st.integers(0, len(words) - 1))
    if how == "bad-token":
        # a character no number holds, inside or around a token
        pos = draw(st.integers(0, len(words[j])))
        words[j] = words[j][:pos] + draw(st.sampled_from("x#@!,;/")) + words[j][pos:]
    elif how == "drop-token":
        del words[j]
    elif how == "extra-token":
        words.insert(j, "1.0")
    elif how == "non-finite":
        words[j] = draw(st.sampled_from(["nan", "NaN", "inf", "-inf", "Infinity", "1e999"]))
    elif how == "duplicate-row":
        lines.insert(k, lines[k])
        return case, _join(lines), f"row doubled at line {k + 1}"
    lines[k] = " ".join(words)
    return case, _join(lines), f"{how} at line {k + 1}"


@pytest.mark.parametrize("which", PARSERS)
@FUZZ
@given(corrupted=corruptions())
def test_corrupted_dumps_fail_loudly_or_give_the_leading_snapshots(folder: Path, which: str,
                                                                   corrupted: tuple) -> None:
    case, text, how = corrupted
    path = write(folder, text)
    n_lines = text.count("\n") + 1
    with parser(which):
        try:
            dump = dumps.read_dump(path, threads=2)
            dumps.check_finite(dump, dump.columns)  # every column counts as read here
        except dumps.DumpError as err:
            match = re.match(rf"{re.escape(str(path))}:(\d+): ", str(err))
            assert match, (how, str(err))
            # the line at fault, or the one after the last when more was expected
            assert 1 <= int(match.group(1)) <= n_lines + 1, (how, str(err))
            return
    # Parsed without error: only a cut exactly between snapshots may do that, and then the
    # result is exactly the snapshots before the cut.
    assert how.startswith("cut"), (how, "a corrupted dump parsed without error")
    assert len(dump) < len(case.snapshots), how
    assert_same(dump, case, len(dump))
