"""Write the C++ header of the parameter vocabulary (CMake runs this at build time).

The one table is ``plugin/vibrofriction/vocabulary.py``; the plugins include the header this
writes (``vocabulary.h`` in the build folder), so a key, a default, a range or the laws a key
acts in are changed in that table alone and every element, the C API and Python follow:

* ``keys::k<Key>``: each MJCF config key of the friction elements (the friction terms and the
  elements' own keys: normal load, vibration, contact and feeder keys);
* ``defaults::k<Key>``: the table's default of each key whose default is a number or a bool (and
  ``kKeyDefaults``, the same by key, which the config readers look up);
* ``kKeyRanges``: (smallest nonzero magnitude, largest) of each key with limits, the range the
  config readers check every number against;
* ``kKeyLaws``: the laws a friction key acts in (bit ``1 << Law``, ``ALL_LAWS``' order);
* ``attributes::k<Plugin>``: the keys each plugin registers with MuJoCo (``plugin_keys``);
* ``kMaxGmsElements``, ``kMaxMapKnots``: the sizes of the laws' lists.

    python vocabulary_header.py OUT.h      # (or no argument: the header on stdout)

vocabulary.py imports nothing but the standard library, so it is loaded from its file
without importing the package (which needs the library this build makes).
"""
from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

VOCABULARY = Path(__file__).resolve().parents[1] / "vibrofriction" / "vocabulary.py"


def load_vocabulary(path: Path = VOCABULARY):
    spec = importlib.util.spec_from_file_location("vibrofriction_vocabulary", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # (dataclasses looks its module up)
    spec.loader.exec_module(module)
    return module


def constant_name(key: str) -> str:
    """The C++ constant of an MJCF key: stribeck_velocity -> kStribeckVelocity."""
    return "k" + "".join(part[:1].upper() + part[1:] for part in key.split("_"))


def cpp_number(value: float) -> str:
    """The shortest double literal that reads back as ``value`` exactly (8e+07, 0.2)."""
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"vocabulary: {value!r} is not a finite number")
    candidates = [repr(value)] + [f"{value:.{digits}e}" for digits in range(17)]
    text = min((c for c in candidates if float(c) == value), key=len)
    return text if any(c in text for c in ".e") else text + ".0"


def header(vocabulary) -> str:
    rows = vocabulary.ALL_KEYS  # every key: the friction terms', then the elements' own
    keys = [row.mjcf_key for row in rows]
    duplicated = sorted({k for k in keys if keys.count(k) > 1})
    if duplicated:
        raise ValueError(f"vocabulary: keys listed twice: {duplicated}")
    out = ["// Generated at build time by plugin/build_hooks/vocabulary_header.py from",
           "// plugin/vibrofriction/vocabulary.py (the one table): do not edit; change the table.",
           "#ifndef VIBROFRICTION_VOCABULARY_H_",
           "#define VIBROFRICTION_VOCABULARY_H_",
           "",
           "namespace vibrofriction {",
           "",
           "// MJCF config keys of the elements",
           "namespace keys {"]
    out += [f'inline constexpr char {constant_name(k)}[] = "{k}";' for k in keys]
    out += ["}  // namespace keys", "",
            "// the table's default of each key whose default is a number or a bool",
            "namespace defaults {"]
    for row in rows:
        default = row.default
        if isinstance(default, bool):
            out.append(f"inline constexpr bool {constant_name(row.mjcf_key)} = "
                       f"{'true' if default else 'false'};")
            continue
        if not isinstance(default, (int, float)):
            continue
        out.append(f"inline constexpr double {constant_name(row.mjcf_key)} = "
                   f"{cpp_number(default)};  // {row.unit}")
    out += ["}  // namespace defaults", "",
            "struct KeyDefault {", "  const char* key;", "  double value;", "};",
            "inline constexpr KeyDefault kKeyDefaults[] = {"]
    for row in rows:
        default = row.default
        if isinstance(default, bool) or not isinstance(default, (int, float)):
            continue
        name = constant_name(row.mjcf_key)
        out.append(f"    {{keys::{name}, defaults::{name}}},")
    out += ["};", "",
            "// (smallest nonzero magnitude, largest) of each key with limits (SI)",
            "struct KeyRange {", "  const char* key;", "  double smallest_nonzero;",
            "  double largest;", "};",
            "inline constexpr KeyRange kKeyRanges[] = {"]
    for row in rows:
        if row.limits is not None:
            smallest, largest = row.limits
            out.append(f"    {{keys::{constant_name(row.mjcf_key)}, {cpp_number(smallest)}, "
                       f"{cpp_number(largest)}}},")
    out += ["};", "",
            "// the laws each friction key acts in: bit 1 << Law (friction_law.h's enum)",
            "struct KeyLaws {", "  const char* key;", "  unsigned laws;", "};",
            "inline constexpr KeyLaws kKeyLaws[] = {"]
    for term in vocabulary.FRICTION_TERMS:
        bits = sum(1 << vocabulary.ALL_LAWS.index(law) for law in term.laws)
        out.append(f"    {{keys::{constant_name(term.mjcf_key)}, 0x{bits:x}u}},  "
                   f"// {', '.join(term.laws)}")
    out += ["};", "",
            "// the keys each plugin vibrofriction.<name> registers with MuJoCo",
            "namespace attributes {"]
    for plugin in vocabulary.ALL_PLUGINS:
        names = ", ".join(f"keys::{constant_name(k)}" for k in vocabulary.plugin_keys(plugin))
        out.append(f"inline constexpr const char* {constant_name(plugin)}[] = {{{names}}};")
    out += ["}  // namespace attributes", "",
            "// the most elements of law gms, the most knots of a level map",
            f"inline constexpr int kMaxGmsElements = {vocabulary.MAX_GMS_ELEMENTS};",
            f"inline constexpr int kMaxMapKnots = {vocabulary.MAX_MAP_KNOTS};",
            "", "}  // namespace vibrofriction", "",
            "#endif  // VIBROFRICTION_VOCABULARY_H_", ""]
    return "\n".join(out)


def main(argv: list[str]) -> int:
    text = header(load_vocabulary())
    if len(argv) > 1:
        target = Path(argv[1])
        # unchanged: leave the file (and what depends on it) as it is
        if not (target.is_file() and target.read_text() == text):
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
