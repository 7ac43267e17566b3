"""One way into every stage: ``python -m pipeline.<stage> [COMMAND] ...``.

A stage's ``__main__`` names its commands and the module whose ``main(argv)`` runs each; this
module picks the command, gives its parser the program name the user typed, and turns the
stage's user errors into one ``error:`` line and exit status 1 (a bug still shows its traceback).
"""
from __future__ import annotations

import importlib
import sys
from collections.abc import Mapping, Sequence


def dispatch(stage: str, commands: Mapping[str, tuple[str, str]], argv: Sequence[str] | None = None,
             default: str | None = None, user_errors: tuple[type[BaseException], ...] = ()) -> int:
    """Run one command of ``python -m pipeline.<stage>``.

    ``commands`` maps a command name to ``(module, one-line help)``; the module's ``main(argv)``
    runs it. With ``default``, arguments that do not start with a command name go to that
    command (so a stage with one main use needs no sub-command).
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
    try:
        return int(module.main(rest) or 0)
    except user_errors as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
