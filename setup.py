"""Builds the extension ccfr._core with the project's CMake build (only that target) for pip."""
import os
import pathlib
import re
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = pathlib.Path(__file__).resolve().parent


def project_version():
    """The version of CMakeLists.txt's project() (ccfr.__version__ is compiled from it too)."""
    m = re.search(r"project\(ccfr\s+VERSION\s+([0-9.]+)", (ROOT / "CMakeLists.txt").read_text())
    if not m:
        raise RuntimeError("CMakeLists.txt: no `project(ccfr VERSION x.y.z ...)`")
    return m.group(1)


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build = pathlib.Path(self.build_temp).resolve() / "cmake"
        gen = ["-G", "Ninja"] if shutil.which("ninja") else []
        subprocess.run(["cmake", "-S", str(ROOT), "-B", str(build), *gen, "-DCMAKE_BUILD_TYPE=Release",
                        "-DCCFR_BUILD_TESTS=OFF", "-DCCFR_BUILD_BENCHMARKS=OFF",
                        f"-DPython3_EXECUTABLE={sys.executable}"], check=True)
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", str(os.cpu_count() or 1))
        subprocess.run(["cmake", "--build", str(build), "--target", "ccfr_python", "--parallel", jobs], check=True)
        built = next((build / "python" / "ccfr").glob("_core*.so"))
        target = pathlib.Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(built, target)


setup(
    version=project_version(),
    packages=["ccfr"],
    package_dir={"": "python"},
    package_data={"ccfr": ["__init__.pyi", "py.typed"]},
    ext_modules=[Extension("ccfr._core", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
)
