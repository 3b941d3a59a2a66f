"""C++ unit tests of the plugin's internals (plugin/cpp/tests/*_test.cc), compiled here against
the checkout's sources and the installed MuJoCo's headers and library, then run: each exits 0
when every check held. Each test names the library sources it needs on a `// sources:` line
(paths relative to plugin/cpp, e.g. laws/friction_law.cc). The vocabulary's header is made here as
the build makes it (plugin/build_hooks/vocabulary_header.py).
CMake builds and registers the same tests with ctest (-DVIBROFRICTION_BUILD_TESTS=ON)."""
from __future__ import annotations

import glob
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import mujoco
import pytest

ROOT = Path(__file__).resolve().parents[1]
CPP = ROOT / "plugin" / "cpp"
TESTS = sorted((CPP / "tests").glob("*_test.cc")) if (CPP / "tests").is_dir() else []


def _compiler() -> str | None:
    return os.environ.get("CXX") or shutil.which("c++") or shutil.which("g++")


@pytest.mark.skipif(not (ROOT / "pyproject.toml").is_file(),
                    reason="not a source checkout: the C++ sources are not here")
def test_there_are_cpp_unit_tests() -> None:
    assert TESTS, f"no *_test.cc in {CPP / 'tests'}"


@pytest.mark.skipif(_compiler() is None, reason="no C++ compiler (c++, g++ or $CXX)")
@pytest.mark.parametrize("source", TESTS, ids=[p.stem for p in TESTS])
def test_cpp_unit(source: Path, tmp_path: Path) -> None:
    listed = re.search(r"^// sources: (.+)$", source.read_text(), re.M)
    assert listed, f"{source.name} names no library sources on a '// sources:' line"
    sources = [str(CPP / name) for name in listed.group(1).split()]
    package = Path(mujoco.__file__).parent
    library = sorted(glob.glob(str(package / "libmujoco.so.*")))
    if not library:
        pytest.skip(f"no libmujoco.so.* in {package} (this test links the Linux library)")
    binary = tmp_path / source.stem
    generated = tmp_path / "generated"
    made = subprocess.run([sys.executable, str(ROOT / "plugin" / "build_hooks" /
                                               "vocabulary_header.py"),
                           str(generated / "vocabulary.h")], capture_output=True, text=True)
    assert made.returncode == 0, made.stderr
    build = subprocess.run(
        [_compiler(), "-O1", "-std=c++17", f"-I{CPP}", f"-I{generated}",
         f"-I{Path(mujoco.HEADERS_DIR).parent}",
         str(source), *sources, f"-L{package}", f"-l:{Path(library[0]).name}",
         f"-Wl,-rpath,{package}", "-o", str(binary)],
        capture_output=True, text=True, timeout=300)
    assert build.returncode == 0, build.stderr[-4000:]
    run = subprocess.run([str(binary)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]
