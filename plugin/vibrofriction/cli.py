"""Console entry point ``vibrofriction`` (also ``python -m vibrofriction``).

Each sub-command lives in ``vibrofriction/commands/<name>.py`` and provides ``HELP``,
``add_arguments(parser)`` and ``run(args) -> int``; what they share is in
``commands/common.py``. The commands never import this module. Bad input exits with code 2 and
one message.
"""
from __future__ import annotations

import argparse
import importlib
import os
import re
import sys
from typing import Any, Sequence

from .laws import MujocoVersionMismatch
from .commands.common import UsageError, check_outputs  # noqa: F401 (UsageError: the API)
from .errors import InputError

# Sub-command name -> module under vibrofriction.commands.
COMMANDS = {
    "simulate": "simulate",
    "sweep": "sweep",
    "reproduce": "reproduce",
    "compare-builtin": "compare_builtin",
    "convert": "convert",
    "identify": "identify",
    "info": "info",
    "view": "view",
}


class ArgumentParser(argparse.ArgumentParser):
    """argparse, with every number that starts with '-' taken as a value, not an option:
    argparse alone knows only -1 and -.5, so ``--va -1e-3`` would be "expected one argument"
    instead of the option's own range check (sub-parsers inherit the class)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"^-(\.?\d|inf|nan)", re.IGNORECASE)


def build_parser() -> argparse.ArgumentParser:
    """The ``vibrofriction`` parser, with one sub-parser per command of ``COMMANDS``."""
    parser = ArgumentParser(
        prog="vibrofriction",
        description="Dynamic friction (Coulomb, Dahl, Dupont, LuGre) with vibrating supports "
                    "in MuJoCo.")
    parser.add_argument("--version", action="version", version=version_line())
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, module_name in COMMANDS.items():
        # (imported when the parser is built, not when the package is)
        module = importlib.import_module(f".commands.{module_name}", __package__)
        # argparse %-formats help strings ("1 %" would break `vibrofriction --help`).
        p = sub.add_parser(name, help=module.HELP.replace("%", "%%"), description=module.HELP)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def version_line() -> str:
    """vibrofriction's version, the MuJoCo its plugin library was built against and the one
    installed (they must be equal: ``_native.check_mujoco_version``)."""
    import mujoco

    from . import __version__, build_info
    return (f"vibrofriction {__version__}, MuJoCo {mujoco.__version__} (plugin built against "
            f"{build_info.MUJOCO_VERSION})")


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line on ``argv`` (default ``sys.argv[1:]``); return the exit status
    (2 for bad input, printed as one line)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
    try:
        check_outputs(args)  # a failing command computes nothing and writes nothing
        return int(args._run(args) or 0)
    except (InputError, FileNotFoundError, MujocoVersionMismatch) as exc:
        print(f"vibrofriction {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except MemoryError as exc:  # a run or a record larger than this machine's memory
        print(f"vibrofriction {args.command}: error: not enough memory ({exc}); ask for less "
              "(a shorter --duration, a larger --timestep, a shorter record)", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader stopped (`vibrofriction info | head`): no traceback
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
