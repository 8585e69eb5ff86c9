"""The same world stepped from Python and from C (pyref.c) has bit-identical state."""
from scenes import column, hexhash, step_adaptive


def test_adaptive_steps_match_c_bitwise(pyref):
    ref = pyref("column3")
    with column(3, 0.04) as w:
        assert len(w) > 1000
        for i in range(1, 21):
            w.step()
            assert hexhash(w) == ref["step %d" % i], "step %d" % i
        assert w.diagnostics()["steps"] == 20


def test_run_frames_match_c_advance_bitwise(pyref):
    ref = pyref("frames2")
    hashes = {}
    with column(2, 0.02) as w:
        w.run(3, 60.0, on_frame=lambda world, f: hashes.__setitem__(f, hexhash(world)))
        assert w.time == 3 / 60.0
    assert sorted(hashes) == [0, 1, 2, 3]
    for f in (1, 2, 3):
        assert hashes[f] == ref["frame %d" % f], "frame %d" % f
    assert hashes[0] != hashes[1]


def test_advance_with_callback_takes_the_same_steps_as_c_advance(pyref):
    ref = pyref("frames2")
    count = [0]
    with column(2, 0.02) as w:
        for f in (1, 2, 3):
            w.advance(f / 60.0, callback=lambda world: count.__setitem__(0, count[0] + 1))
            assert w.time == f / 60.0
            assert hexhash(w) == ref["frame %d" % f]
        assert count[0] == w.diagnostics()["steps"] > 3


def test_velocity_written_through_the_view_changes_the_next_step_as_in_c(pyref):
    ref = pyref("kick")
    with column(3, 0.04) as w:
        step_adaptive(w, 5)
        before = hexhash(w)
        v = w.velocities
        v[7] = (0.5, 1.0, -0.25)
        # the view is the library's memory: the state hash (computed by C) sees the write at once
        assert hexhash(w) == ref["kicked"] != before
        assert tuple(w.velocities[7]) == (0.5, 1.0, -0.25)
        step_adaptive(w, 5)
        assert hexhash(w) == ref["after"]
    with column(3, 0.04) as plain:
        step_adaptive(plain, 10)
        assert hexhash(plain) != ref["after"]


def test_thread_count_does_not_change_the_bits(pyref):
    ref = pyref("column3")
    with column(3, 0.04) as w:
        w.set_threads(1)
        step_adaptive(w, 10)
        w.set_threads(2)
        step_adaptive(w, 10)
        assert hexhash(w) == ref["step 20"]


def test_worlds_stepped_from_two_python_threads_match_c_bitwise(pyref):
    """Each calling thread has its own pool of step threads (src/core/team.h): two Python threads,
    each stepping its own world on 2 threads, both reach the C reference; their pools end with them."""
    import threading

    ref = pyref("column3")
    results = {}

    def run(name):
        with column(3, 0.04) as w:
            w.set_threads(2)
            step_adaptive(w, 20)
            results[name] = hexhash(w)

    for _round in range(3):
        threads = [threading.Thread(target=run, args=(k,)) for k in range(2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert results == {0: ref["step 20"], 1: ref["step 20"]}
        results.clear()
