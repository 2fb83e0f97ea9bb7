"""State views are zero-copy and read-only; the setters and kinematic targets do what they say."""
import gc

import ccfr
import numpy as np
import pytest


def handle_sim(data, **over):
    return ccfr.Simulation(ccfr.load_scene(data / "handle.yaml", overrides=over or None), threads=2)


def test_views_are_zero_copy_read_only_and_follow_the_steps(data):
    sim = handle_sim(data)
    x, v = sim.positions, sim.velocities
    assert x.shape == (sim.num_vertices, 3) and x.dtype == np.float64
    assert not x.flags.writeable and not v.flags.writeable and not x.flags.owndata
    with pytest.raises(ValueError):
        x[0, 0] = 1.0
    address = x.__array_interface__["data"][0]
    before = x.copy()
    sim.set_velocities(np.tile([0.0, 0.0, 0.3], (sim.num_vertices, 1)))
    sim.step()
    # Same buffer, new values: the view taken before the step shows the state after it.
    assert sim.positions.__array_interface__["data"][0] == address
    assert not np.array_equal(x, before)
    assert np.array_equal(x, sim.positions)
    # The view keeps the simulation alive.
    del sim
    gc.collect()
    assert np.isfinite(x).all() and x.sum() == x.sum()


def test_set_positions_and_velocities_closed_form(data):
    # No gravity, no damping: a free particle moves by v / fps in one frame (its only constraint-free
    # vertex; the strip's pinned ends keep it in place).
    sim = handle_sim(data)
    n = sim.num_vertices
    grain = n - 1
    x = sim.positions.copy()
    x[grain] = [0.05, 0.4, -0.02]
    sim.set_positions(x)
    assert np.array_equal(sim.positions, x)
    v = np.zeros((n, 3))
    v[grain] = [0.6, -1.2, 0.3]
    sim.set_velocities(v)
    assert np.array_equal(sim.velocities, v)
    sim.step()
    np.testing.assert_allclose(sim.positions[grain], x[grain] + v[grain] / 60.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(sim.velocities[grain], v[grain], rtol=0, atol=1e-9)


def test_masses_are_the_lumped_masses_and_weigh_the_momentum():
    # Closed form: the cloth strip's vertex masses add up to its areal density x 0.4 m x 0.1 m, the
    # grain's is its material's density (kg a grain); a free grain's momentum is m v.
    scene = ccfr.load_scene_text(
        """
time: {fps: 60, frames: 1, substeps: 4, gravity: [0, 0, 0], damping: 0}
materials: {sheet: {density: 0.3}, sand: {density: 0.002}}
objects:
  - {name: strip, kind: cloth, material: sheet, shape: {type: grid, size: [0.4, 0.1], resolution: [8, 2]}}
  - name: grain
    kind: particles
    material: sand
    shape: {type: particles, counts: [1, 1, 1], spacing: 0.01}
    transform: {translate: [0, 0.5, 0]}
"""
    )
    sim = ccfr.Simulation(scene, threads=2)
    m = sim.masses
    assert m.shape == (sim.num_vertices,) and m.dtype == np.float64
    strip = scene.objects[0]
    assert m[strip["vertex_begin"] : strip["vertex_end"]].sum() == pytest.approx(0.3 * 0.4 * 0.1, rel=1e-12)
    assert m[-1] == 0.002
    v = np.zeros((sim.num_vertices, 3))
    v[-1] = [0.0, 0.0, 2.0]
    sim.set_velocities(v)
    sim.step()
    assert (m[:, None] * sim.velocities)[-1, 2] == pytest.approx(0.004, rel=1e-9)


@pytest.mark.parametrize("bad", [np.zeros((3, 3)), np.zeros((5,)), "text"])
def test_setters_refuse_wrong_shapes(data, bad):
    sim = handle_sim(data)
    with pytest.raises((ccfr.Error, ValueError)):
        sim.set_positions(bad)
    with pytest.raises((ccfr.Error, ValueError)):
        sim.set_velocities(bad)


def test_setters_refuse_non_finite_values(data):
    sim = handle_sim(data)
    x = sim.positions.copy()
    x[2, 1] = np.nan
    with pytest.raises(ValueError, match="positions row 2 is not finite"):  # a bad argument: ValueError
        sim.set_positions(x)


def test_kinematic_targets_reach_the_target_at_the_frame_end_and_hold(data):
    sim = handle_sim(data)
    pinned = sim.kinematic_vertices
    strip = next(o for o in ccfr.load_scene(data / "handle.yaml").objects if o["name"] == "strip")
    assert len(pinned) == 6 and all(strip["vertex_begin"] <= i < strip["vertex_end"] for i in pinned)
    left = pinned[sim.positions[pinned, 0] < 0]
    start = sim.positions[left].copy()
    target = start + [0.0, 0.02, 0.005]  # 20.6 mm in a frame: 4 substeps of 5.2 mm, each below r = 10 mm
    sim.set_kinematic_targets(left, target)
    sim.step()
    assert np.array_equal(sim.positions[left], target)
    # Velocity of a driven vertex: its last substep's step over dt (linear motion: the frame's).
    np.testing.assert_allclose(sim.velocities[left], np.tile([0.0, 1.2, 0.3], (len(left), 1)), atol=1e-9)
    # The other end did not move, and the column next to the handle (x = -0.15) was pulled up.
    right = pinned[sim.positions[pinned, 0] > 0]
    rest = ccfr.load_scene(data / "handle.yaml").positions
    next_column = [i for i in range(strip["vertex_begin"], strip["vertex_end"]) if abs(rest[i, 0] + 0.15) < 1e-9]
    assert len(next_column) == 3 and np.all(sim.positions[next_column, 1] > 0.004)
    sim.step()
    assert np.array_equal(sim.positions[left], target)  # holds without a new target
    assert np.array_equal(sim.positions[right], ccfr.load_scene(data / "handle.yaml").positions[right])


def test_kinematic_targets_refuse_dynamic_vertices_and_bad_input(data):
    sim = handle_sim(data)
    dynamic = sim.num_vertices - 1
    with pytest.raises(ccfr.Error, match="neither pinned nor part of an obstacle"):
        sim.set_kinematic_targets([dynamic], [[0, 0, 0]])
    with pytest.raises(ccfr.Error, match="out of range"):
        sim.set_kinematic_targets([sim.num_vertices], [[0, 0, 0]])
    pinned = sim.kinematic_vertices
    with pytest.raises(ccfr.Error, match="2 vertex indices but 1 targets"):
        sim.set_kinematic_targets(pinned[:2], [[0, 0, 0]])
    with pytest.raises(ccfr.Error, match="not finite"):
        sim.set_kinematic_targets(pinned[:1], [[0, np.inf, 0]])
    with pytest.raises(ValueError):
        sim.set_kinematic_targets([0.5], [[0, 0, 0]])


def test_a_target_beyond_what_subdivision_absorbs_is_a_guarantee_error(data):
    sim = handle_sim(data, **{"time.max_subdivision": 2})
    pinned = sim.kinematic_vertices
    # 1 m in one frame: 4 substeps x 2 pieces x 0.9 r = 72 mm at most.
    sim.set_kinematic_targets(pinned[:1], sim.positions[pinned[:1]] + [1.0, 0, 0])
    with pytest.raises(ccfr.GuaranteeError, match="time.substeps") as info:
        sim.step()
    assert info.value.frame == 1
