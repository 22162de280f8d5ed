"""The runner: the same results in this process and on Ray, saved per unit, resumed, and
failures reported by name."""

from __future__ import annotations

import numpy as np
import pytest

from brake_env.runner import Later, Runner, Unit, UnitsFailed, UnitStore


def draw(seed: int, n: int) -> dict:
    """A unit whose result depends on its arguments alone."""
    rng = np.random.default_rng(seed)
    return {"x": rng.normal(size=n), "mean": float(rng.normal()), "tag": (seed, "s"), "nan": np.nan}


def fail_on(seed: int, bad: int) -> int:
    if seed == bad:
        raise ValueError(f"seed {seed} is bad")
    return seed * 2


def mean_of(shared: np.ndarray, i: int) -> float:
    return float(shared[i::3].mean())


def units(n: int = 5) -> list[Unit]:
    return [Unit(f"seed={s}", draw, (s, 4)) for s in range(n)]


def same(a: dict, b: dict) -> None:
    assert list(a) == list(b)
    for k in a:
        np.testing.assert_array_equal(a[k]["x"], b[k]["x"])
        assert a[k]["mean"] == b[k]["mean"] and a[k]["tag"] == b[k]["tag"]
        assert np.isnan(b[k]["nan"])


def test_units_give_the_same_results_in_process_and_on_ray(local_ray):
    here = Runner(0).run(units())
    with Runner(workers=2) as r:
        assert r.on_ray
        big = r.share(np.arange(3000.0))
        on_ray = r.run(units())
        means = r.run([Unit(f"m{i}", mean_of, (big, i)) for i in range(3)])
    same(here, on_ray)
    assert means == {f"m{i}": float(np.arange(3000.0)[i::3].mean()) for i in range(3)}


def test_a_store_resumes_from_the_finished_units(tmp_path):
    store = UnitStore(tmp_path, {"seed": 0, "n": 4})
    seen: list[str] = []
    first = Runner(0).run(units(3), store)
    again = Runner(0).run(units(5), UnitStore(tmp_path, {"seed": 0, "n": 4}),
                          progress=lambda k, _: seen.append(k))  # fmt: skip
    same(first, {k: again[k] for k in first})
    same(Runner(0).run(units(5)), again)
    assert sorted(seen) == [f"seed={s}" for s in range(5)]
    assert store.keys() == [f"seed={s}" for s in range(5)]


def test_a_store_refuses_a_run_with_other_settings(tmp_path):
    UnitStore(tmp_path, {"seed": 0, "n": 4})
    with pytest.raises(ValueError, match=r"n: 4 -> 5"):
        UnitStore(tmp_path, {"seed": 0, "n": 5})


def test_a_changed_result_file_is_refused(tmp_path):
    store = UnitStore(tmp_path, {})
    store.save("a", {"x": np.arange(3)})
    npz = next(tmp_path.glob("*.npz"))
    blob = bytearray(npz.read_bytes())
    blob[-1] ^= 0xFF
    npz.write_bytes(bytes(blob))
    with pytest.raises(ValueError, match="unit a"):
        store.load("a")


def test_a_result_that_cannot_be_saved_is_named(tmp_path):
    with pytest.raises(TypeError, match="set"):
        UnitStore(tmp_path, {}).save("a", {"x": {1, 2}})


@pytest.mark.parametrize("workers", [0, 2])
def test_failed_units_are_named_after_the_others_are_saved(tmp_path, workers, request):
    if workers:
        request.getfixturevalue("local_ray")
    store = UnitStore(tmp_path, {})
    todo = [Unit(f"s{s}", fail_on, (s, 2)) for s in range(4)]
    with Runner(workers) as r, pytest.raises(UnitsFailed, match=r"s2: ValueError: seed 2 is bad"):
        r.run(todo, store)
    assert store.keys() == ["s0", "s1", "s3"]
    assert Runner(0).run(todo[:2] + todo[3:], store) == {"s0": 0, "s1": 2, "s3": 6}


def test_duplicate_keys_are_refused():
    with pytest.raises(ValueError, match="unique"):
        Runner(0).run([Unit("a", fail_on, (0, 1)), Unit("a", fail_on, (1, 2))])


def test_a_store_written_by_other_code_is_not_resumed(tmp_path, monkeypatch):
    import brake_env.units as units_module

    UnitStore(tmp_path, {"seed": 0})
    monkeypatch.setattr(units_module, "code_digest", lambda: "edited")
    with pytest.raises(ValueError, match=r"code: '[0-9a-f]{16}' -> 'edited'"):
        UnitStore(tmp_path, {"seed": 0})


def test_a_killed_writes_temporary_file_is_not_a_unit(tmp_path):
    store = UnitStore(tmp_path, {})
    store.save("a", 1)
    (tmp_path / ".b-123.json.99-ab.tmp.json").write_text("{")
    assert store.keys() == ["a"] and "b" not in store


# ------------------------------------------------------------ units that need others' results
def add(a: int, b: int) -> int:
    return a + b


def graph() -> list:
    """fit -> two users of it -> a summary of both; ``fit`` is not kept."""
    return [
        Unit("fit", fail_on, (5, -1)),  # 10
        Later("a", ("fit",), lambda r: Unit("a", add, (r["fit"], 1), weight=1.0)),
        Later("b", ("fit",), lambda r: Unit("b", add, (r["fit"], 2), weight=3.0)),
        Later("sum", ("a", "b"), lambda r: Unit("sum", add, (r["a"], r["b"]))),
    ]


@pytest.mark.parametrize("workers", [0, 2])
def test_a_graph_runs_each_unit_after_what_it_needs(tmp_path, workers, request):
    if workers:
        request.getfixturevalue("local_ray")
    store = UnitStore(tmp_path, {})
    seen: list[str] = []
    with Runner(workers) as r:
        got = r.run_graph(graph(), store, lambda k, v: seen.append(k), kept=lambda k: k != "fit")
    assert got == {"fit": 10, "a": 11, "b": 12, "sum": 23}
    assert store.keys() == ["a", "b", "sum"]  # the fit is not kept
    assert seen.index("fit") < min(seen.index("a"), seen.index("b")) < seen.index("sum")
    # resumed: nothing left needs the fit, so it does not run
    again = Runner(0).run_graph(graph(), store, kept=lambda k: k != "fit")
    assert again == {"a": 11, "b": 12, "sum": 23}


def test_a_graph_reruns_an_unkept_unit_only_for_what_needs_it(tmp_path):
    store = UnitStore(tmp_path, {})
    store.save("a", 11)
    store.save("sum", 23)
    got = Runner(0).run_graph(graph(), store, kept=lambda k: k != "fit")
    assert got == {"fit": 10, "a": 11, "b": 12, "sum": 23}  # b needs the fit again


@pytest.mark.parametrize("workers", [0, 2])
def test_a_graph_names_failures_and_what_they_stopped(workers, request):
    if workers:
        request.getfixturevalue("local_ray")
    nodes = graph()
    nodes[2] = Later("b", ("fit",), lambda r: Unit("b", fail_on, (r["fit"], 10)))
    with Runner(workers) as r, pytest.raises(UnitsFailed) as e:
        r.run_graph(nodes)
    assert set(e.value.errors) == {"b", "sum"}
    assert "seed 10 is bad" in str(e.value) and "sum: RuntimeError: not run: it needs b" in str(
        e.value
    )


def test_a_graph_refuses_a_node_before_what_it_needs():
    with pytest.raises(ValueError, match="sum needs"):
        Runner(0).run_graph([graph()[3], *graph()[:3]])


def started_at(pause: float) -> float:
    import time

    t = time.monotonic()  # one clock for the machine's processes
    time.sleep(pause)
    return t


def test_on_ray_the_heaviest_ready_units_start_first(local_ray):
    light = [Unit(f"light{i}", started_at, (0.0,)) for i in range(2)]
    heavy = [Unit(f"heavy{i}", started_at, (0.3,), weight=5.0) for i in range(2)]
    with Runner(workers=2) as r:  # two CPUs: two units at a time
        t = r.run_graph([*light, *heavy])
    assert max(t["heavy0"], t["heavy1"]) < min(t["light0"], t["light1"])


def test_a_graph_names_a_unit_whose_make_raised():
    nodes = graph()
    nodes[1] = Later("a", ("fit",), lambda r: Unit("a", add, (r["no such unit"], 1)))
    with pytest.raises(UnitsFailed) as e:
        Runner(0).run_graph(nodes)
    assert set(e.value.errors) == {"a", "sum"} and "KeyError" in str(e.value)
