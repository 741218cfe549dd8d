"""The paper estimator's inverses are shared by the estimators of a process (a monitor builds one per cycle)
and give the numbers a fresh inverse gives; another set or another wear term is another inverse."""

from __future__ import annotations

import numpy as np

from jointwear_ros.estimation import make_estimator
from jointwear_ros.estimation.inverse import WearInverse, shared_inverse
from jointwear_ros.model import load_parameter_set, paper_wear_model
from jointwear_ros.model.parameters import Parameter, Parameters


def test_estimators_of_one_set_share_their_inverses_and_estimate_as_before():
    a = make_estimator("paper", params="ref-2011r", seed=1)
    b = make_estimator("paper", params="ref-2011r", seed=2)
    inner_a, inner_b = (getattr(e, "estimator", e) for e in (a, b))
    assert inner_a.inverse(47.0) is inner_b.inverse(47.0)
    m, p = paper_wear_model(), load_parameter_set("ref-2011r")
    fresh = WearInverse(m, p, 47.0)
    z = np.linspace(-0.01, 0.05, 101)
    np.testing.assert_array_equal(shared_inverse(m, p, 47.0)(z), fresh(z))
    np.testing.assert_array_equal(shared_inverse(m, p, 47.0).exact(z), fresh.exact(z))


def test_another_set_or_a_changed_value_is_another_inverse():
    m, p = paper_wear_model(), load_parameter_set("ref-2011r")
    first = shared_inverse(m, p, 47.0)
    changed = Parameters(Parameter(n, v.value * (1.5 if n == "Fvw" else 1.0), v.vary) for n, v in p.items())
    assert shared_inverse(m, changed, 47.0) is not first
    assert shared_inverse(m, p, 80.0) is not first
    assert shared_inverse(m, p, 47.0, (0.0, 50.0)) is not first
    assert shared_inverse(m, p, 47.0) is first


def test_estimators_in_threads_share_the_cache_through_its_evictions():
    # a Dask worker of several threads estimates bags at once: every lookup gets the inverse of its own speed,
    # and one thread's eviction (more speeds than the cache keeps) never breaks another's lookup
    import threading

    from jointwear_ros.estimation import inverse

    m, p = paper_wear_model(), load_parameter_set("ref-2011r")
    speeds = [10.0 + k for k in range(inverse._SHARED_MAX + 6)]
    start = threading.Barrier(3)
    errors: list[BaseException] = []

    def work(order: list[float]) -> None:
        start.wait()
        try:
            for _ in range(2):
                for v in order:
                    assert shared_inverse(m, p, v).speed == v
        except BaseException as exc:  # reported below
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(o,)) for o in (speeds, speeds[::-1], speeds[1::2] + speeds[::2])]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    assert len(inverse._SHARED) <= inverse._SHARED_MAX
    assert shared_inverse(m, p, speeds[-1]) is shared_inverse(m, p, speeds[-1])
