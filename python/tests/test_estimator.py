"""`tolles.TollesLawson`, the scikit-learn style estimator."""

import numpy as np
import pytest

import tolles


@pytest.fixture(scope="module")
def cal():
    return tolles.simulate(plan="box", seed=2)


def test_params_round_trip_and_unknown_ones_are_refused():
    est = tolles.TollesLawson(scalar="mag_1_uc", lambda_=0.001, level="model")
    params = est.get_params()
    assert params["lambda_"] == 0.001 and params["level"] == "model"
    assert tolles.TollesLawson(**params).get_params() == params
    assert est.set_params(order=2).order == 2
    with pytest.raises(ValueError):
        est.set_params(nonsense=1)


def test_fit_then_transform_equals_the_functions(cal):
    est = tolles.TollesLawson().fit(cal)
    assert est.model_ == tolles.fit(cal)
    out = est.transform(cal)
    np.testing.assert_array_equal(out["mag_1_c"], tolles.compensate(cal, est.model_)["mag_1_c"])
    with pytest.raises(AttributeError, match="not fitted"):
        tolles.TollesLawson().transform(cal)


def test_it_works_in_a_scikit_learn_pipeline(cal):
    sklearn = pytest.importorskip("sklearn")
    from sklearn.base import clone
    from sklearn.pipeline import Pipeline

    pipe = Pipeline([("tl", tolles.TollesLawson(terms="permanent,induced,eddy", lambda_=0.001))])
    out = pipe.fit(cal).transform(cal)
    direct = tolles.compensate(cal, tolles.fit(cal, terms="permanent,induced,eddy", lambda_=0.001))
    np.testing.assert_array_equal(out["mag_1_c"], direct["mag_1_c"])
    copy = clone(pipe.named_steps["tl"])
    assert copy.get_params() == pipe.named_steps["tl"].get_params()
    assert not hasattr(copy, "model_")
    assert sklearn.__version__
