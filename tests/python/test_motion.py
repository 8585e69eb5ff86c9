"""Colliders moved by a Python callable (through an ffi.callback), as a scene's Lua motion function."""
import math

import pytest

import sandmpm as sm
from scenes import PLATE_V, PLATE_X0, PLATE_Y0, front_velocity, hexhash, plate, plate_motion


def test_python_motion_matches_the_c_motion_function_bitwise(pyref):
    ref = pyref("plate", "motion")
    w, pid = plate(plate_motion)
    with w:
        w.advance(0.1)
        assert hexhash(w) == ref["hash"]
        assert w.collider_pose(pid)[0][0] == float(ref["plate_x"]) == PLATE_X0 + PLATE_V * 0.1
        vx, n = front_velocity(w, pid)
        assert vx == float(ref["front_vx"]) and n == int(ref["front_n"])
        assert w.diagnostics()["center_of_mass"][0] == float(ref["com_x"])


def test_plate_pushes_sand_at_its_velocity_as_the_constant_velocity_collider(pyref):
    const = pyref("plate", "const")
    w, pid = plate(plate_motion)
    with w:
        w.advance(0.1)
        vx, n = front_velocity(w, pid)
        com_x = w.diagnostics()["center_of_mass"][0]
    # the sand in front of the face moves with the plate (sticky), a little slower (it also rises)
    assert n > 50
    assert vx == pytest.approx(PLATE_V, rel=0.15)
    # the finite-difference velocity of a scripted pose is the constant velocity up to rounding
    assert vx == pytest.approx(float(const["front_vx"]), rel=1e-6)
    assert com_x == pytest.approx(float(const["com_x"]), rel=1e-9)
    assert float(const["plate_x"]) == pytest.approx(PLATE_X0 + PLATE_V * 0.1, abs=1e-12)
    # without the plate's motion the layer only slumps: its centre of mass stays at x = 0.5
    still, sid = plate(lambda t: (PLATE_X0, PLATE_Y0))
    with still:
        still.advance(0.1)
        assert abs(still.diagnostics()["center_of_mass"][0] - 0.5) < 0.2 * (com_x - 0.5)
        assert front_velocity(still, sid)[0] < 0.1 * PLATE_V


def test_motion_with_rotation_turns_the_collider():
    turn = math.radians(30)
    with sm.World(dim=3, dx=0.05) as w:
        c = sm.Collider(sm.Shape.box((0, 0, 0), (0.2, 0.02, 0.2)),
                        motion=lambda t: ((0.5, 0.5, 0.5), sm.axis_angle((0, 0, 1), math.degrees(turn) * t)))
        cid = w.add_collider(c)
        w.step(0.01)
        w.step(0.01)
        pos, rot = w.collider_pose(cid)
        assert pos == (0.5, 0.5, 0.5)
        assert rot == pytest.approx((math.cos(turn * 0.01), 0, 0, math.sin(turn * 0.01)), abs=1e-12)


class Fault(Exception):
    pass


def test_an_exception_in_the_motion_callable_propagates_after_the_step():
    calls = []

    def motion(t):
        calls.append(t)
        if 0.05 <= t and len([c for c in calls if c >= 0.05]) == 1:
            raise Fault("bad pose")
        return plate_motion(t)

    w, pid = plate(motion)
    with w:
        with pytest.raises(Fault, match="bad pose") as e:
            w.advance(0.1)
        assert any("motion function of collider 1" in n for n in getattr(e.value, "__notes__", []))
        # stopped after the step in which it raised; the collider kept its last good pose
        t_fail = [c for c in calls if c >= 0.05][0]
        assert w.time == pytest.approx(t_fail, abs=1e-15)
        last_good = [c for c in calls if c < 0.05][-1]
        assert w.collider_pose(pid)[0][0] == PLATE_X0 + PLATE_V * last_good
        # the world goes on: the callable is called again at the next step
        w.advance(0.1)
        assert w.time == 0.1 and w.collider_pose(pid)[0][0] == PLATE_X0 + PLATE_V * 0.1


def test_exception_in_step_and_bad_results_raise():
    def motion(t):
        if t > 0.015:
            return "nowhere"
        return (0.5, 0.5)

    with sm.World(dim=2, dx=0.05) as w:
        w.add_collider(sm.Collider(sm.Shape.sphere((0, 0), 0.1), motion=motion))
        w.step(0.01)
        with pytest.raises(TypeError, match="returned position"):
            w.step(0.01)
        assert w.time == pytest.approx(0.02)


def test_motion_errors_before_the_collider_is_added():
    with sm.World(dim=2, dx=0.05) as w:
        with pytest.raises(ZeroDivisionError):
            w.add_collider(sm.Collider(sm.Shape.sphere((0, 0), 0.1), motion=lambda t: (1 / t, 0)))
        with pytest.raises(ValueError, match="about z"):
            w.add_collider(sm.Collider(sm.Shape.sphere((0, 0), 0.1),
                                       motion=lambda t: ((0, 0), sm.axis_angle((1, 0, 0), 10))))
        assert sm.lib.sm_world_collider_count(w._w) == 0
