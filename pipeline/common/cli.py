"""One way into every stage: ``python -m pipeline.<stage> [COMMAND] ...``.

A stage's ``__main__`` names its commands and the module whose ``main(argv)`` runs each; this
module picks the command, gives its parser the program name the user typed, and turns the
stage's user errors into one ``error:`` line and exit status 1 (a bug still shows its traceback).
"""
from __future__ import annotations

import argparse
import importlib
import math
import os
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path


def dispatch(stage: str, commands: Mapping[str, tuple[str, str]], argv: Sequence[str] | None = None,
             default: str | None = None, user_errors: tuple[type[BaseException], ...] = (),
             out_is_folder: bool = False) -> int:
    """Run one command of ``python -m pipeline.<stage>``.

    ``commands`` maps a command name to ``(module, one-line help)``; the module's ``main(argv)``
    runs it. With ``default``, arguments that do not start with a command name go to that
    command (so a stage with one main use needs no sub-command). ``--out`` is checked before the
    command runs (:func:`output_problem`); ``out_is_folder`` where it names a folder (a DEM run's).
    """
    args = list(sys.argv[1:] if argv is None else argv)
    prog = f"python -m pipeline.{stage}"
    if args and args[0] in commands:
        name, rest = args[0], args[1:]
    elif default is not None and not (args and args[0] in ("-h", "--help") and len(commands) > 1):
        name, rest = default, args
    else:
        width = max(map(len, commands))
        lines = [f"usage: {prog} COMMAND [options]   ({prog} COMMAND --help for its options)", "", "commands:"]
        lines += [f"  {n:<{width}}  {text}" for n, (_, text) in commands.items()]
        if default is not None:
            lines += ["", f"Without a command, the arguments go to '{default}'."]
        known = args and not args[0].startswith("-")
        stream = sys.stderr if known else sys.stdout
        if known:
            print(f"{prog}: error: unknown command {args[0]!r}", file=stream)
        print("\n".join(lines), file=stream)
        return 2 if known or not args else 0
    module = importlib.import_module(commands[name][0])
    sys.argv[0] = prog if name == default else f"{prog} {name}"
    problem = output_problem(rest, out_is_folder)
    if problem:
        print(f"{sys.argv[0]}: error: {problem}", file=sys.stderr)
        return 2
    try:
        return int(module.main(rest) or 0)
    except user_errors as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1


def output_problem(args: Sequence[str], out_is_folder: bool = False) -> str | None:
    """Why the ``--out`` of a command line cannot be written, checked before any work is done: a
    file output that is a folder (or a folder output that is a file), a parent that is a file, or
    one that cannot be written in. None when it can."""
    for k, arg in enumerate(args):
        value = args[k + 1] if arg == "--out" and k + 1 < len(args) else (arg[6:] if arg.startswith("--out=") else None)
        if value is None:
            continue
        path = Path(value)
        if path.is_dir() and not out_is_folder:
            return f"--out {value}: is a folder; give a file name"
        if out_is_folder and path.exists() and not path.is_dir():
            return f"--out {value}: is a file; give the run folder"
        parent = path.parent
        while not parent.exists() and parent != parent.parent:
            parent = parent.parent
        if parent.exists() and not parent.is_dir():
            return f"--out {value}: {parent} is a file, not a folder"
        if parent.exists() and not os.access(parent, os.W_OK):
            return f"--out {value}: cannot write in {parent}"
    return None


def _number(kind: type, text: str, check, expected: str) -> float | int:
    try:
        value = kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a{'n integer' if kind is int else ' number'}") from None
    if not (math.isfinite(value) and check(value)):
        raise argparse.ArgumentTypeError(f"{text!r}: expected {expected}")
    return value


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0 (0, negative, nan and inf are refused, never replaced)."""
    return _number(float, text, lambda v: v > 0, "a finite number above 0")


def nonnegative_float(text: str) -> float:
    """argparse type: a finite number >= 0."""
    return _number(float, text, lambda v: v >= 0, "a finite number of 0 or more")


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    return _number(int, text, lambda v: v >= 1, "an integer of 1 or more")
