"""scikit-learn's estimator contract without importing scikit-learn.

:class:`Estimator` gives ``get_params`` / ``set_params`` read from the ``__init__`` signature,
as :class:`sklearn.base.BaseEstimator` does, so :func:`sklearn.base.clone` and grid searches
work on topomap's estimators; :func:`clone` is the same copy for the library's own use.
Importing ``sklearn.base`` costs half a second (it loads most of scikit-learn), more than a
whole ``topomap segment`` spends segmenting a floor, hence this module.

The contract (scikit-learn's developer guide): ``__init__`` stores its parameters as given and
does nothing else; ``fit`` validates them (:meth:`Estimator._validate_params`) and sets the
fitted attributes, whose names end in ``_``; a sub-estimator given as a parameter is cloned
before it is fitted, never fitted in place.
"""

from __future__ import annotations

import inspect
import math
from typing import Any, TypeGuard, TypeVar

import numpy as np

from segmentation.errors import NotFittedError, ParameterError

E = TypeVar("E", bound="Estimator")


class Estimator:
    """``get_params`` and ``set_params`` from the parameters of ``__init__``.

    Examples
    --------
    >>> from segmentation.spectral import SpectralSegmenter
    >>> model = SpectralSegmenter(k=3).set_params(p=0.5)
    >>> model.get_params()["p"], clone(model).k
    (0.5, 3)
    """

    def __getattr__(self, name: str) -> Any:
        """Only names not set: a fitted attribute before ``fit`` is a typed error.

        Examples
        --------
        >>> from segmentation.spectral import SpectralSegmenter
        >>> SpectralSegmenter().labels_
        Traceback (most recent call last):
        ...
        segmentation.errors.NotFittedError: SpectralSegmenter is not fitted: call fit before ...
        >>> hasattr(SpectralSegmenter(), "labels_")
        False
        """
        if name.endswith("_") and not name.startswith("_"):
            raise NotFittedError(
                f"{type(self).__name__} is not fitted: call fit before reading {name}"
            )
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    @classmethod
    def _get_param_names(cls) -> list[str]:
        """The names of the ``__init__`` parameters, sorted."""
        parameters = inspect.signature(cls.__init__).parameters.values()
        kinds = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
        return sorted(p.name for p in parameters if p.name != "self" and p.kind not in kinds)

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """The parameters by name; with ``deep``, a sub-estimator's too as ``name__param``."""
        params: dict[str, Any] = {}
        for name in self._get_param_names():
            value = getattr(self, name)
            if deep and hasattr(value, "get_params") and not isinstance(value, type):
                params.update((f"{name}__{k}", v) for k, v in value.get_params().items())
            params[name] = value
        return params

    def set_params(self: E, **params: Any) -> E:
        """Set parameters (``name__param`` for a sub-estimator's); returns the estimator.

        Raises
        ------
        ParameterError
            Naming a parameter the estimator does not have.
        """
        names = self._get_param_names()
        nested: dict[str, dict[str, Any]] = {}
        for key, value in params.items():
            name, nest, sub = key.partition("__")
            if name not in names:
                raise ParameterError(
                    f"{type(self).__name__} has no parameter {name!r}; it has {', '.join(names)}"
                )
            if nest:
                nested.setdefault(name, {})[sub] = value
            else:
                setattr(self, name, value)
        for name, sub_params in nested.items():
            inner = getattr(self, name)
            if not hasattr(inner, "set_params"):
                raise ParameterError(
                    f"{type(self).__name__}.{name} is {inner!r}, not an estimator: "
                    f"{', '.join(f'{name}__{sub}' for sub in sub_params)} cannot be set"
                )
            inner.set_params(**sub_params)
        return self

    def _validate_params(self) -> None:
        """Raise :class:`~segmentation.errors.ParameterError` for a parameter out of range
        (called first by ``fit``)."""


def clone(estimator: E, **changes: Any) -> E:
    """A new, unfitted estimator with the same parameters and ``changes`` applied.

    Sub-estimators are cloned; other values are shared, not deep-copied as
    :func:`sklearn.base.clone` does: no ``fit`` changes a parameter, and a criterion holding a
    large map (:class:`~segmentation.affinity.PassageAffinity`) is not copied per block.

    Examples
    --------
    >>> from segmentation.pipeline import MapSegmenter
    >>> pipeline = MapSegmenter(spacing=3.0)
    >>> copied = clone(pipeline, robot_radius=0.3)
    >>> copied.spacing, copied.robot_radius, copied.spectral is pipeline.spectral
    (3.0, 0.3, False)
    """
    params = {
        name: clone(value) if isinstance(value, Estimator) and name not in changes else value
        for name, value in estimator.get_params(deep=False).items()
    }
    return type(estimator)(**{**params, **changes})


def check_lengths(estimator: object, *names: str) -> None:
    """Raise :class:`~segmentation.errors.ParameterError` unless each parameter ``names`` of
    ``estimator`` is a finite number of metres above 0.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> check_lengths(SimpleNamespace(reach=-1.0), "reach")
    Traceback (most recent call last):
    ...
    segmentation.errors.ParameterError: reach must be a finite number > 0 metres, got -1.0
    """
    for name in names:
        value = getattr(estimator, name)
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise ParameterError(f"{name} must be a finite number > 0 metres, got {value!r}")


def is_count(value: object) -> TypeGuard[int | np.integer]:
    """Whether ``value`` is an integer (Python's or numpy's), not a bool: ``k=True`` is no
    count of regions.

    Examples
    --------
    >>> is_count(3), is_count(np.int64(3)), is_count(True), is_count(2.0)
    (True, True, False, False)
    """
    return isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)


def check_flags(estimator: object, *names: str) -> None:
    """Raise :class:`~segmentation.errors.ParameterError` unless each parameter ``names`` of
    ``estimator`` is True or False (the string "no" is truthy).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> check_flags(SimpleNamespace(dense="no"), "dense")
    Traceback (most recent call last):
    ...
    segmentation.errors.ParameterError: dense must be True or False, got 'no'
    """
    for name in names:
        value = getattr(estimator, name)
        if not isinstance(value, bool | np.bool_):
            raise ParameterError(f"{name} must be True or False, got {value!r}")
