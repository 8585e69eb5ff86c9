"""Bad arguments raise: the library's status and message, or TypeError/ValueError from the binding."""
import math

import pytest

import sandmpm as sm


def c_message(check, cdata, *args):
    """The message the library's own check writes for a definition."""
    err = sm.ffi.new("char[512]")
    st = check(cdata, *args, err, 512)
    return st, sm.ffi.string(err).decode()


def test_world_def_error_carries_the_library_status_and_message():
    d = sm.ffi.new("sm_world_def *", sm.lib.sm_world_def_default())
    d.dx = -1
    st, msg = c_message(sm.lib.sm_world_def_check, d)
    assert st == sm.Status.ERR_INVALID and "dx" in msg
    with pytest.raises(sm.Error) as e:
        sm.World(dx=-1)
    assert e.value.status == sm.Status.ERR_INVALID
    assert e.value.message == msg
    assert msg in str(e.value) and "invalid input" in str(e.value)


def test_material_error_is_the_library_check():
    m = sm.ffi.new("sm_material_def *", sm.lib.sm_material_def_sand())
    m.poisson_ratio = 0.7
    st, msg = c_message(sm.lib.sm_material_def_check, m)
    assert st == sm.Status.ERR_INVALID and "0.7" in msg
    with pytest.raises(sm.Error) as e:
        sm.Material.sand(poisson_ratio=0.7)
    assert e.value.message == msg


def test_world_call_errors_carry_sm_world_errmsg():
    with sm.World(dim=2, dx=0.05) as w:
        with pytest.raises(sm.Error) as e:
            w.step(-1.0)
        assert e.value.status == sm.Status.ERR_INVALID
        assert e.value.message == sm.ffi.string(sm.lib.sm_world_errmsg(w._w)).decode()
        assert "dt" in e.value.message and "-1" in e.value.message
        with pytest.raises(sm.Error) as e:
            w.seed(sm.Shape.sphere((0.5, 0.5), 0.1), material=7)
        assert e.value.status == sm.Status.ERR_INVALID and "material" in e.value.message
        with pytest.raises(sm.Error) as e:
            w.advance(math.inf)
        assert "finite" in e.value.message
        bad = sm.Collider(sm.Shape.sphere((0.5, 0.5), 0.1), friction=-1)
        with pytest.raises(sm.Error, match="friction"):
            w.add_collider(bad)
        assert sm.lib.sm_world_collider_count(w._w) == 0
        with pytest.raises(sm.Error, match="rate|start|stop|emitter|shape"):
            w.add_emitter(sm.Emitter(sm.Shape.sphere((0.5, 0.5), 0.05), sm.Material.sand(), rate=-1))


def test_unknown_keywords_raise_type_error_with_a_suggestion():
    with pytest.raises(TypeError, match=r"unexpected keyword argument 'dxx'.*did you mean 'dx'"):
        sm.World(dxx=0.1)
    with pytest.raises(TypeError, match="did you mean 'friction_angle'"):
        sm.Material.sand(friction_angel=30)
    with pytest.raises(TypeError, match="did you mean 'friction'"):
        sm.Collider(sm.Shape.sphere((0, 0, 0), 1), fricton=0.3)
    with pytest.raises(TypeError, match="did you mean 'ppc'"):
        with sm.World(dim=2, dx=0.05) as w:
            w.seed(sm.Shape.sphere((0.5, 0.5), 0.1), sm.Material.sand(), ppcc=4)
    with pytest.raises(TypeError, match="unexpected keyword argument 'kind'"):
        sm.Material.sand(kind=1)


def test_enum_fields_take_names_and_refuse_unknown_ones():
    w = sm.World(dim=2, dx=0.05, kernel="cubic", transfer="flip", wall_mode="slip", integrator="implicit")
    d = w.definition
    assert (d["kernel"], d["transfer"], d["wall_mode"], d["integrator"]) == ("cubic", "flip", "slip", "implicit")
    w.close()
    with pytest.raises(ValueError, match=r"unknown value 'cubc'.*did you mean 'cubic'"):
        sm.World(kernel="cubc")
    with pytest.raises(ValueError, match="sticky"):
        sm.Collider(sm.Shape.sphere((0, 0, 0), 1), mode="stick")
    with pytest.raises(ValueError, match="poisson"):
        with sm.World(dim=2, dx=0.05) as w:
            w.seed(sm.Shape.sphere((0.5, 0.5), 0.1), sm.Material.sand(), method="possion")


def test_wrong_types_and_lengths_raise():
    with pytest.raises(TypeError, match="dx: expected a number"):
        sm.World(dx="small")
    with pytest.raises(ValueError, match="gravity: expected 3 numbers, got 4"):
        sm.World(gravity=(0, -9.81, 0, 1))
    with pytest.raises(TypeError, match="dim: expected an integer"):
        sm.World(dim=2.5)
    with pytest.raises(ValueError, match="out of range"):
        sm.World(max_particles=-1)
    with pytest.raises(TypeError, match="Shape"):
        sm.Collider("ground")
    with pytest.raises(ValueError, match="1 to 16"):
        sm.Collider([sm.Shape.sphere((0, 0, 0), 1)] * 17)
    with pytest.raises(TypeError, match="callable"):
        sm.Collider(sm.Shape.sphere((0, 0, 0), 1), motion=3)


def test_defaults_are_the_library_defaults():
    d = sm.World.defaults()
    c = sm.lib.sm_world_def_default()
    assert d["dx"] == c.dx and d["max_dt"] == c.max_dt and d["gravity"] == tuple(c.gravity)
    assert d["kernel"] == "quadratic" and d["wall_mode"] == "separate"
    names = [f for f, _ in sm.ffi.typeof("sm_world_def").fields]
    assert list(d) == names
    with sm.World() as w:
        assert w.definition == d
    m = sm.Material.sand()
    assert m.density == sm.lib.sm_material_def_sand().density and m.hardening == 1
    assert sm.Material.elastic().kind == "elastic"
    with pytest.raises(AttributeError, match="immutable"):
        m.density = 1
    assert m.replace(density=1500).density == 1500 and m.density == 2200
