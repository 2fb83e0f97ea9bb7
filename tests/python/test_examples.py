"""The examples of examples/python run (briefly) and end with a passing audit."""
import os
import subprocess
import sys

import pytest

EXAMPLES = {
    "twist_handle.py": ["--frames", "6"],
    "cloth_from_arrays.py": ["--frames", "6", "--resolution", "10"],
    "ablation.py": ["--frames", "3", "--quick", "--solvers", "ccfr", "toi_clamp", "--offsets", "0.01"],
}


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_example_runs(name, tmp_path, source_dir):
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (os.environ.get("CCFR_PYTHON_DIR"), env.get("PYTHONPATH")) if p)
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, str(source_dir / "examples" / "python" / name), "--out", str(out),
                        "--threads", "2", *EXAMPLES[name]], capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    if name == "ablation.py":
        assert (out / "ablation.png").stat().st_size > 0
        assert r.stdout.count(" pass") == 2
    else:
        assert "audit: pass" in r.stdout
        assert (out / "run.json").exists() and (out / "frames" / "frame_00006.obj").exists()
