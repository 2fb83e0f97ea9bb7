"""scripts/side_by_side.py on run folders written here: the panel titles say what the audit.json
beside them says (pass and fail over the run, the frame shown clean or with its findings, its
closest pair), the image has both panels side by side, and bad input exits 2."""
import importlib.util
import json
import os
import pathlib
import subprocess
import sys

import pytest

SCRIPT = pathlib.Path(os.environ.get("CCFR_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2])) / "scripts" / \
    "side_by_side.py"


def load_script():
    spec = importlib.util.spec_from_file_location("side_by_side", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def frame_row(frame, tri=0, seg=0, close=0, dist=None):
    return {"frame": frame, "file": f"frame_{frame:05d}.obj", "triangle_intersections": tri,
            "segment_crossings": seg, "close_pairs": close, "min_distance": dist, "examples": []}


def run_dir(tmp_path, name, solver, audit, status=None):
    d = tmp_path / name
    d.mkdir()
    (d / "run.json").write_text(json.dumps({"solver": solver, **({"status": status} if status else {})}))
    (d / "audit.json").write_text(json.dumps(audit))
    return d


PASSING = {"verdict": "pass", "offset": 0.01, "frames_checked": 481, "min_distance": 0.009999999999,
           "violations": 0, "bad_frames": 0, "first_bad_frame": None,
           "frames": [frame_row(0), frame_row(300, dist=0.01)]}
FAILING = {"verdict": "fail", "offset": 0.01, "frames_checked": 301, "min_distance": 2.6e-7,
           "violations": 128423, "bad_frames": 234, "first_bad_frame": 63,
           "frames": [frame_row(0), frame_row(300, tri=724, close=1623, dist=0.0001033)]}


def test_captions_say_what_the_audit_says(tmp_path):
    mod = load_script()
    text, colour = mod.caption(str(run_dir(tmp_path, "a", "ccfr", PASSING)), 300)
    assert text.splitlines() == ["ccfr", "audit PASS: 481 frames, min distance 1.000 ξ", "frame 300: clean",
                                 "closest pair 1.00000 ξ"]
    assert colour == "#2e7d32"
    text, colour = mod.caption(str(run_dir(tmp_path, "b", "post_process", FAILING)), 300)
    assert text.splitlines() == ["post_process", "audit FAIL: 128,423 violations in 234 of 301 frames (first: frame 63)",
                                 "frame 300: 724 triangle intersections, 1,623 pairs closer than ξ",
                                 "closest pair 0.01033 ξ"]
    assert colour == "#c62828"


def test_a_clean_run_stopped_early_is_neither_passed_nor_failed(tmp_path):
    mod = load_script()
    stopped = {**PASSING, "verdict": "incomplete", "frames_checked": 151, "min_distance": 0.0100000011}
    text, colour = mod.caption(str(run_dir(tmp_path, "a", "dat", stopped)), 300)
    assert text.splitlines()[:2] == ["dat", "audit INCOMPLETE (run not finished): 151 frames clean, min 1.000 ξ"]
    assert colour not in ("#2e7d32", "#c62828")
    bad = {**FAILING, "verdict": "incomplete"}  # stopped early and found violations: still red, with counts
    text, colour = mod.caption(str(run_dir(tmp_path, "b", "ogc", bad)), 300)
    assert text.splitlines()[1] == "audit INCOMPLETE: 128,423 violations in 234 of 301 frames (first: frame 63)"
    assert colour == "#c62828"


@pytest.mark.parametrize("status, why", [
    ("stopped at its time limit of 45 min 00 s after frame 150", "run stopped at its time limit"),
    ("failed: frame 15: scripted vertices of object 'sheet' lag their script", "run stopped by its error"),
    ("interrupted after frame 2", "run interrupted"),
    ("terminated after frame 9 (SIGTERM)", "run interrupted"),
    ("running", "run not finished"),
])
def test_a_clean_partial_run_says_why_it_is_partial(tmp_path, status, why):
    mod = load_script()
    stopped = {**PASSING, "verdict": "incomplete", "frames_checked": 15, "min_distance": 0.0100076}
    text, colour = mod.caption(str(run_dir(tmp_path, "a", "toi_clamp", stopped, status)), 14)
    assert text.splitlines()[1] == f"audit INCOMPLETE ({why}): 15 frames clean, min 1.001 ξ"
    assert colour == "#b26a00"


def test_long_captions_are_wrapped_to_the_panel_width():
    mod = load_script()
    text = ("toi_clamp\naudit INCOMPLETE (run stopped at its time limit): 97 frames clean, min 1.000 ξ"
            "\nframe 96: clean")
    wrapped = mod.wrap_caption(text, 480)
    chars = int(480 / (0.6 * 10 * 100 / 72))
    assert all(len(line) <= chars for line in wrapped.split("\n"))
    assert wrapped.count("\n") > text.count("\n")  # the long line was broken
    assert wrapped.split() == text.split()  # and nothing was lost or reordered
    assert mod.wrap_caption("dat\nframe 3: clean", 480) == "dat\nframe 3: clean"  # short lines stay


def test_a_frame_the_audit_skipped_is_named_as_such(tmp_path):
    mod = load_script()
    text, _ = mod.caption(str(run_dir(tmp_path, "a", "ccfr", PASSING)), 150)
    assert text.splitlines()[-1] == "frame 150 not audited"
    text, _ = mod.caption(str(run_dir(tmp_path, "b", "ccfr", PASSING)), 0)  # no pair in range: no distance
    assert text.splitlines()[-1] == "frame 0: clean"


def test_a_run_that_never_came_near_anything_passes_without_a_distance(tmp_path):
    mod = load_script()
    free = {**PASSING, "frames_checked": 5, "min_distance": None, "frames": [frame_row(4)]}
    text, colour = mod.caption(str(run_dir(tmp_path, "a", "ogc", free)), 4)
    assert text.splitlines() == ["ogc", "audit PASS: 5 frames, no pair within range", "frame 4: clean"]
    assert colour == "#2e7d32"


def test_writes_both_panels_side_by_side(tmp_path):
    pytest.importorskip("matplotlib")
    import matplotlib.image as mpimg
    import numpy as np
    a, b = run_dir(tmp_path, "a", "ccfr", PASSING), run_dir(tmp_path, "b", "post_process", FAILING)
    red, blue = np.zeros((60, 80, 3)), np.zeros((60, 80, 3))
    red[..., 0], blue[..., 2] = 1.0, 1.0
    mpimg.imsave(tmp_path / "a.png", red)
    mpimg.imsave(tmp_path / "b.png", blue)
    out = tmp_path / "out.png"
    r = subprocess.run([sys.executable, str(SCRIPT), "--run", str(a), str(tmp_path / "a.png"), "--run", str(b),
                        str(tmp_path / "b.png"), "--frame", "300", "--out", str(out), "--title", "T"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    img = mpimg.imread(out)
    assert img.shape[1] == 160  # two 80-pixel panels at 100 dpi
    # The left panel's pixels are red, the right one's blue (titles sit above the images).
    row = img[img.shape[0] // 2 + 20]
    assert row[40][0] > 0.9 and row[40][2] < 0.1
    assert row[120][2] > 0.9 and row[120][0] < 0.1


def test_missing_audit_exits_2(tmp_path):
    d = tmp_path / "a"
    d.mkdir()
    (d / "run.json").write_text("{}")
    pytest.importorskip("matplotlib")
    import matplotlib.image as mpimg
    import numpy as np
    mpimg.imsave(tmp_path / "x.png", np.zeros((8, 8, 3)))
    r = subprocess.run([sys.executable, str(SCRIPT), "--run", str(d), str(tmp_path / "x.png"), "--frame", "1",
                        "--out", str(tmp_path / "o.png")], capture_output=True, text=True)
    assert r.returncode == 2
    assert "audit.json" in r.stderr
