"""The scikit-learn style estimator, kept apart so that ``import tolles`` does not import
scikit-learn (a second or more): ``tolles.TollesLawson`` loads this module on first use."""

from __future__ import annotations

from typing import Any, Optional, Tuple, Union

import pandas as pd

from . import Names, compensate, fit

_Base: tuple
try:  # scikit-learn is optional: with it, the estimator gets its cloning, tags and HTML repr.
    from sklearn.base import BaseEstimator as _SkBase, TransformerMixin as _SkMixin

    _Base = (_SkMixin, _SkBase)
except ImportError:  # pragma: no cover - exercised when scikit-learn is absent
    _Base = (object,)


class TollesLawson(*_Base):  # type: ignore[misc]
    """A scikit-learn style transformer: ``fit`` learns a model from a calibration flight,
    ``transform`` compensates a DataFrame (adding ``mag_1_c``, …).

    Parameters are those of :func:`fit` plus ``level`` of :func:`compensate`; after ``fit``,
    ``model_`` holds the :class:`Model`.

    >>> from sklearn.pipeline import make_pipeline            # doctest: +SKIP
    >>> pipe = make_pipeline(TollesLawson(scalar="mag_1_uc", vector="flux_a"))  # doctest: +SKIP
    >>> survey_c = pipe.fit(cal).transform(survey)            # doctest: +SKIP
    """

    def __init__(
        self,
        scalar: Names = "mag_1_uc",
        vector: Names = "flux_a",
        terms: str = "auto",
        lambda_: Union[str, float] = "auto",
        band: Tuple[float, float] = (0.1, 0.9),
        order: int = 4,
        trim: int = 20,
        fs: Optional[float] = None,
        level: str = "mean",
    ):
        self.scalar = scalar
        self.vector = vector
        self.terms = terms
        self.lambda_ = lambda_
        self.band = band
        self.order = order
        self.trim = trim
        self.fs = fs
        self.level = level

    _PARAMS = ("scalar", "vector", "terms", "lambda_", "band", "order", "trim", "fs", "level")

    def get_params(self, deep: bool = True) -> dict:
        return {name: getattr(self, name) for name in self._PARAMS}

    def set_params(self, **params: Any) -> "TollesLawson":
        for name, value in params.items():
            if name not in self._PARAMS:
                raise ValueError(f"TollesLawson has no parameter {name!r}")
            setattr(self, name, value)
        return self

    def fit(self, X: pd.DataFrame, y: Any = None) -> "TollesLawson":
        """Fit on the calibration flight ``X`` (``y`` is ignored: the scalar is a column)."""
        self.model_ = fit(
            X,
            self.scalar,
            self.vector,
            terms=self.terms,
            lambda_=self.lambda_,
            band=self.band,
            order=self.order,
            trim=self.trim,
            fs=self.fs,
        )
        return self

    def transform(self, X: pd.DataFrame) -> pd.DataFrame:
        """``X`` with the compensated columns added (nT)."""
        if not hasattr(self, "model_"):
            raise AttributeError("TollesLawson is not fitted yet; call fit first")
        return compensate(X, self.model_, level=self.level, fs=self.fs)

    def fit_transform(self, X: pd.DataFrame, y: Any = None, **fit_params: Any) -> pd.DataFrame:
        return self.fit(X, y).transform(X)
