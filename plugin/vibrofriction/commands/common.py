"""What the sub-commands share: the usage error, the common options, the output checks and
the atomic JSON writer. The commands import this, never ``cli``, which imports them: the
command line is the top layer, with no cycle."""
from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path
from typing import Any, Sequence

from ..errors import InputError


class UsageError(InputError):
    """Bad input from the user: printed as one line, exit code 2."""


def add_common_arguments(parser: argparse.ArgumentParser, *, law: bool = True,
                         timestep: bool = True) -> None:
    """Options the model commands share (docs/interfaces.md); ``timestep=False`` for a command
    that chooses its own timesteps (compare-builtin), so --timestep is not offered at all."""
    parser.add_argument("--set", dest="overrides", action="append", default=[],
                        metavar="NAME=VALUE",
                        help="override a parameter (repeatable), e.g. --set mass_kg=0.5")
    if law:
        parser.add_argument("--law", default="dahl",
                            help="friction law: coulomb, dahl, dupont, lugre or gms (default dahl)")
    if timestep:
        parser.add_argument("--timestep", type=float, default=None, metavar="S",
                            help="simulation timestep in seconds (default: N + 0.382 steps per "
                                 "vibration period, N = 50 doubled per doubling of kappa_v "
                                 "above 10)")
    parser.add_argument("--json", dest="json_path", type=Path, default=None, metavar="FILE",
                        help="write the machine-readable result to FILE")


def parse_overrides(pairs: Sequence[str]) -> dict[str, str]:
    """``--set`` values ``NAME=VALUE`` -> {NAME: VALUE} (strings, stripped; a later NAME wins);
    UsageError for an entry without ``=``."""
    out: dict[str, str] = {}
    for pair in pairs:
        if "=" not in pair:
            raise UsageError(f"--set expects NAME=VALUE, got {pair!r}")
        name, value = pair.split("=", 1)
        out[name.strip()] = value.strip()
    return out


def write_json(path: Path | None, payload: Any) -> None:
    """Write JSON atomically (temp file + rename) so a failure leaves nothing half-written;
    inside ``datasets.all_or_nothing()`` together with the block's other outputs."""
    from ..data.datasets import stage_file

    from ..provenance import json_text

    text = json_text(payload)
    if path is None:
        print(text, end="")
        return
    path = Path(path)
    check_output_file(path, "the output")
    stage_file(path, text.encode())


def check_output_file(path: Path | None, option: str) -> None:
    """UsageError when ``path`` cannot become a file: it is a folder, or one of its parents is a
    file (checked before a command runs, so nothing is computed in vain or left half-done)."""
    if path is None:
        return
    path = Path(path)
    if path.is_dir():
        raise UsageError(f"{option} {path} is a folder; name a file")
    for parent in path.parents:
        if parent.exists() and not parent.is_dir():
            raise UsageError(f"{option} {path}: {parent} is a file, not a folder")


def check_writable(path: Path, option: str, *, inside: bool = False) -> None:
    """UsageError when the folder that will hold ``path`` (the nearest that exists; with
    ``inside``, ``path`` itself when it is a folder) cannot take a new file: tried with a
    temporary file, removed at once."""
    path = Path(path)
    folder = path if inside and path.is_dir() else Path(os.path.abspath(path)).parent
    while not folder.exists():
        folder = folder.parent
    try:
        handle, probe = tempfile.mkstemp(dir=folder, prefix=".vibrofriction-probe.",
                                         suffix=".tmp")
        os.close(handle)
        os.unlink(probe)
    except OSError as exc:
        raise UsageError(f"{option} {path}: cannot write in {folder} "
                         f"({exc.strerror or exc}); choose a folder you can write to") from None


def check_outputs(args: argparse.Namespace) -> None:
    """Every output target of the command, before it runs: a failing command computes nothing
    and writes nothing (the writes themselves are all-or-nothing: datasets.all_or_nothing)."""
    from ..data.datasets import sidecar_path

    files: list[tuple[str, str, Path]] = []  # (label in messages, what it is, file)
    out = getattr(args, "out", None)
    if out is not None and args.command != "convert":
        check_output_folder(out, "--out")
        check_writable(out, "--out")  # (the folder is replaced: its parent takes the new one)
        json_path = getattr(args, "json_path", None)
        if json_path is not None:
            folder = Path(os.path.abspath(out))
            if folder in Path(os.path.abspath(json_path)).parents:
                raise UsageError(f"--json {json_path} is inside --out {out}, which is "
                                 "replaced as a whole; write it outside")
        out = None
    for option, path in (("--csv", getattr(args, "csv_path", None)), ("--out", out)):
        if path is not None:
            path = Path(path)
            check_output_file(path, option)  # (a folder is named as such, not as a bad name)
            files += [(option, option, path),
                      (f"{option} {path}: its sidecar", f"the sidecar of {option} {path}",
                       sidecar_path(path))]
    if getattr(args, "json_path", None) is not None:
        files.append(("--json", "--json", Path(args.json_path)))
    seen: dict[Path, str] = {}
    for label, what, path in files:
        check_output_file(path, label)
        check_writable(path, label)
        key = Path(os.path.abspath(path))
        if key in seen:
            raise UsageError(f"{label} {path} is also written as {seen[key]}; name another "
                             "file")
        seen[key] = what


def check_output_folder(path: Path | None, option: str) -> None:
    """UsageError when ``path`` cannot become a folder (an existing file is in the way)."""
    if path is None:
        return
    path = Path(path)
    for candidate in (path, *path.parents):
        if candidate.exists() and not candidate.is_dir():
            raise UsageError(f"{option} {path}: {candidate} is a file; name a folder")


def check_replaceable_folder(path: Path, option: str, marker: str,
                             foreign: dict[str, str] | None = None) -> None:
    """UsageError unless ``path`` may be replaced as a whole: absent, empty, or an earlier
    output of the same command (it holds ``marker`` and no file of ``foreign``: file -> the
    command that writes it), and not holding the current folder."""
    folder = Path(os.path.abspath(path))
    for name, command in (foreign or {}).items():
        if (folder / name).is_file():
            raise UsageError(f"{option} {path} holds {name}, the output of {command}, and "
                             "would be replaced as a whole; name another folder")
    cwd = Path(os.path.abspath(Path.cwd()))
    if cwd == folder or folder in cwd.parents:
        raise UsageError(f"{option} {path} holds the current folder and would be replaced as "
                         "a whole; name another folder")
    if folder.is_dir() and any(folder.iterdir()) and not (folder / marker).is_file():
        raise UsageError(f"{option} {path} is a folder that is not an earlier output (no "
                         f"{marker}) and would be replaced as a whole; name a new folder or "
                         "empty it")
