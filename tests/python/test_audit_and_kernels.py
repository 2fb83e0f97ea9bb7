"""ccfr.audit against `ccfr audit`; projectors against closed forms; closest points against sampling."""
import json
import shutil
import subprocess

import ccfr
import numpy as np
import pytest


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory, data):
    out = tmp_path_factory.mktemp("audit") / "run"
    sim = ccfr.Simulation(ccfr.load_scene(data / "small_drop.yaml", overrides={"time.frames": 4}), threads=2)
    with ccfr.Run(sim, out) as run:
        run.step(sim.frames)
    return out


def test_audit_passes_and_matches_ccfr_audit(run_dir, ccfr_exe, tmp_path):
    result = ccfr.audit(run_dir)
    assert result.verdict == "pass" and result and result.clean
    assert [r.frame for r in result.rows] == [0, 1, 2, 3, 4]
    assert result.frames_checked == 5 and result.offset == 0.01 and result.status == "completed"
    cli_dir = tmp_path / "cli"
    shutil.copytree(run_dir, cli_dir)
    cli = subprocess.run([ccfr_exe, "audit", str(cli_dir)], capture_output=True, text=True)
    assert cli.returncode == 0
    report = json.loads((cli_dir / "audit.json").read_text())
    assert report["verdict"] == "pass"
    assert report["min_distance"] == pytest.approx(result.min_distance, rel=1e-12)
    assert min(r.min_distance for r in result.rows) == result.min_distance


def test_audit_fails_a_frame_with_a_vertex_pushed_through(run_dir, tmp_path, ccfr_exe):
    bad = tmp_path / "bad"
    shutil.copytree(run_dir, bad)
    frame = bad / "frames" / "frame_00004.obj"
    lines = frame.read_text().splitlines()
    # The cloth's centre vertex (index 112 of 225) moved into the ball's centre.
    vs = [i for i, l in enumerate(lines) if l.startswith("v ")]
    lines[vs[112]] = "v 0 0 0"
    frame.write_text("\n".join(lines) + "\n")
    result = ccfr.audit(bad, write_report=True)
    assert result.verdict == "fail" and not result and result.first_bad_frame == 4
    assert [r.clean for r in result.rows] == [True, True, True, True, False]
    assert result.rows[-1].triangle_intersections > 0
    report = json.loads((bad / "audit.json").read_text())
    assert report["verdict"] == "fail" and report["exit_code"] == 1
    assert subprocess.run([ccfr_exe, "audit", str(bad)], capture_output=True).returncode == 1


def test_audit_incomplete_unless_partial(run_dir, tmp_path):
    part = tmp_path / "part"
    shutil.copytree(run_dir, part)
    info = json.loads((part / "run.json").read_text())
    info["status"] = "running"
    (part / "run.json").write_text(json.dumps(info))
    assert ccfr.audit(part).verdict == "incomplete"
    assert ccfr.audit(part, partial=True).verdict == "pass"


def closed_form(anchor, x0, planes):
    """x0 - A^T (A A^T)^-1 (A x0 - b) for the equalities n_k . (x - anchor) + d_k = 0."""
    A = planes[:, :3]
    b = A @ anchor - planes[:, 3]
    return x0 - A.T @ np.linalg.solve(A @ A.T, A @ x0 - b)


@pytest.mark.parametrize("method", ["plesnik", "exact"])
@pytest.mark.parametrize("k", [1, 2, 3])
def test_projection_onto_violated_planes_is_the_closed_form(method, k):
    rng = np.random.default_rng(7 + k)
    tested = 0
    for _ in range(200):
        anchor = rng.normal(size=3)
        normals = rng.normal(size=(k, 3))
        normals /= np.linalg.norm(normals, axis=1)[:, None]
        d = rng.uniform(0.01, 0.1, size=k)
        planes = np.column_stack([normals, d])
        # A candidate whose orthogonal projection onto all k planes is feasible: every plane active.
        target = closed_form(anchor, anchor, planes)  # a point on all k planes
        candidate = target - normals.T @ rng.uniform(0.05, 0.2, size=k)
        expected = closed_form(anchor, candidate, planes)
        # The closed form is the projection when every plane is violated at the candidate and the
        # projection satisfies them all (then all are active at the answer).
        if np.any((candidate - anchor) @ normals.T + d >= 0) or np.any((expected - anchor) @ normals.T + d < -1e-9):
            continue
        tested += 1
        r = ccfr.project(anchor, candidate, planes, method=method, epsilon=0.0)
        assert r.status == "projected" and r.active == k
        if method == "exact" or k == 1:
            np.testing.assert_allclose(r.x, expected, atol=1e-9)
        else:
            # Plesník skips planes that an earlier equation already satisfied: a feasible point, never
            # closer to the candidate than the Euclidean projection.
            assert np.all((r.x - anchor) @ normals.T + d >= -1e-9)
            assert np.linalg.norm(r.x - candidate) >= np.linalg.norm(expected - candidate) - 1e-9
    assert tested >= 20


def test_projection_degenerate_inputs():
    a = np.zeros(3)
    r = ccfr.project(a, [1.0, 2.0, 3.0], np.zeros((0, 4)))  # no planes: feasible, unchanged
    assert r.status == "feasible" and np.array_equal(r.x, [1.0, 2.0, 3.0])
    r = ccfr.project(a, [0, -1.0, 0], [[0, 1, 0, 0.1], [0, 1, 0, 0.1]], epsilon=0.0)  # a repeated plane
    assert r.status == "projected" and np.allclose(r.x, [0, -0.1, 0])
    with pytest.raises(ValueError, match="candidate must be finite"):  # bounded like scene coordinates
        ccfr.project(a, [np.nan, 0, 0], [[0, 1, 0, 0.1]])
    assert set(ccfr.projector_names()) >= {"plesnik", "exact", "successive_projection"}
    with pytest.raises(ValueError):
        ccfr.project(a, a, [[0, 1, 0]])


def test_closest_points_against_dense_sampling():
    rng = np.random.default_rng(3)
    s = np.linspace(0, 1, 401)
    for _ in range(20):
        p, a, b, c = rng.normal(size=(4, 3))
        pe = ccfr.point_edge(p, a, b)
        sampled = np.min(np.linalg.norm(a + np.outer(s, b - a) - p, axis=1))
        assert pe["distance"] <= sampled + 1e-12 and sampled - pe["distance"] < 1e-2
        np.testing.assert_allclose(pe["closest"], a + pe["t"] * (b - a), atol=1e-12)
        pt = ccfr.point_triangle(p, a, b, c)
        u, v = np.meshgrid(s[::4], s[::4])
        mask = u + v <= 1
        pts = a + np.outer(u[mask], b - a) + np.outer(v[mask], c - a)
        sampled = np.min(np.linalg.norm(pts - p, axis=1))
        assert pt["distance"] <= sampled + 1e-12 and sampled - pt["distance"] < 2e-2
        assert pt["bary"].min() >= 0 and abs(pt["bary"].sum() - 1) < 1e-12
        a1, b0, b1 = rng.normal(size=(3, 3))
        ee = ccfr.edge_edge(a, a1, b0, b1)
        pa = a + np.outer(s[::4], a1 - a)
        pb = b0 + np.outer(s[::4], b1 - b0)
        sampled = np.min(np.linalg.norm(pa[:, None, :] - pb[None, :, :], axis=2))
        assert ee["distance"] <= sampled + 1e-12 and sampled - ee["distance"] < 2e-2
    # Degenerate: a zero-length edge and a point on the triangle.
    assert ccfr.point_edge([0, 1, 0], [0, 0, 0], [0, 0, 0])["distance"] == pytest.approx(1.0)
    assert ccfr.point_triangle([0.2, 0, 0.2], [0, 0, 0], [1, 0, 0], [0, 0, 1])["feature"] == "interior"
    assert ccfr.edge_edge([0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0])["parallel"]
