"""First-order optimisers on flat parameter vectors: SGD (with momentum), RMSprop and Adam.

The paper tunes the OrthoQNN experiments over ``optimiser in {Adam, SGD, RMSProp}`` with a
learning rate in ``[1e-4, 1e-2]`` (Supp. "Hyperparameters") and trains the equivariant and
re-uploading models with Adam at ``lr = 0.001``. The optimisers here work on one flat vector
(:func:`qdensity.learning.nn.get_flat`), so quantum angles, mixture logits and classical weights are
updated together:

>>> import numpy as np
>>> from qdensity.learning.optim import Adam
>>> opt = Adam(lr=0.1)
>>> x = np.array([1.0, -2.0])
>>> for _ in range(200):
...     x = opt.step(x, 2.0 * x)          # gradient of ||x||^2
>>> bool(np.all(np.abs(x) < 0.05))
True

``step(params, grads)`` is pure with respect to its arguments (it returns a new array and never
writes into ``params`` or ``grads``); the optimiser's own moment estimates live inside it and
are exported by ``state_dict()`` as plain floats and arrays, ready for
:func:`qdensity.learning.nn.save_parameters` (``.npz`` or JSON).
"""

from __future__ import annotations

import abc
import numbers
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["Optimizer", "SGD", "RMSprop", "Adam"]


def _check_real(
    value,
    name: str,
    *,
    low: float,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = True,
) -> float:
    """A finite real in the given interval, as a Python float."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {value!r}")
    v = float(value)
    lo_ok = v > low if low_open else v >= low
    hi_ok = True if high is None else (v < high if high_open else v <= high)
    if not np.isfinite(v) or not lo_ok or not hi_ok:
        left = "(" if low_open else "["
        right = "inf)" if high is None else (f"{high:g})" if high_open else f"{high:g}]")
        raise ValueError(f"{name} must lie in {left}{low:g}, {right}, got {value!r}")
    return v


def _check_step_int(value, name: str) -> int:
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be an int, got {value!r}")
    if isinstance(value, numbers.Integral):
        v = int(value)
    elif isinstance(value, numbers.Real) and float(value).is_integer():
        v = int(float(value))  # JSON readers may hand back 3.0
    else:
        raise TypeError(f"{name} must be an int, got {value!r}")
    if v < 0:
        raise ValueError(f"{name} must be >= 0, got {v}")
    return v


def _check_vector(x, name: str, size: int | None) -> np.ndarray:
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be a vector of real numbers, got {x!r}") from exc
    if arr.ndim != 1:
        raise ValueError(f"{name} must be a flat 1-d vector, got shape {arr.shape}")
    if size is not None and arr.size != size:
        raise ValueError(
            f"{name} must have shape ({size},) (the size this optimiser was started with), "
            f"got {arr.shape}; call reset() to start on a new parameter vector"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return arr


class Optimizer(abc.ABC):
    """Common interface: ``step``, ``state_dict``, ``load_state_dict``, ``reset``.

    Parameters
    ----------
    lr : float
        Learning rate, ``> 0``. Settable later (validated), e.g. by a schedule.

    Attributes
    ----------
    t : int
        Number of steps taken since construction or :meth:`reset`.

    Examples
    --------
    An optimiser's state moves to a fresh one, which then continues exactly (a resumed fit):

    >>> import numpy as np
    >>> from qdensity.learning.optim import SGD
    >>> opt = SGD(lr=0.1, momentum=0.9); p = opt.step(np.zeros(2), np.ones(2))
    >>> resumed = SGD(lr=0.5); resumed.load_state_dict(opt.state_dict())
    >>> resumed.t, resumed.lr, np.array_equal(resumed.step(p, np.ones(2)), opt.step(p, np.ones(2)))
    (1, 0.1, True)
    """

    _hyper: tuple[str, ...] = ("lr",)
    _buffers: tuple[str, ...] = ()

    def __init__(self, lr: float) -> None:
        self.lr = lr
        self.reset()

    @property
    def lr(self) -> float:
        return self._lr

    @lr.setter
    def lr(self, value: float) -> None:
        self._lr = _check_real(value, "lr", low=0.0, low_open=True, high=None)

    def reset(self) -> None:
        """Forget all state (step count and moment buffers); hyperparameters are kept."""
        self.t = 0
        self._size: int | None = None
        for name in self._buffers:
            setattr(self, name, None)

    def step(self, params, grads) -> np.ndarray:
        """One update.

        Parameters
        ----------
        params : array_like, shape (P,)
            Current parameters (not modified).
        grads : array_like, shape (P,)
            Gradient of the loss at ``params`` (not modified).

        Returns
        -------
        numpy.ndarray, shape (P,)
            New parameters.
        """
        p = _check_vector(params, "params", self._size)
        g = _check_vector(grads, "grads", p.size)
        if self._size is None:
            self._size = p.size
            for name in self._buffers:
                setattr(self, name, np.zeros(p.size))
        self.t += 1
        return self._update(p, g)

    @abc.abstractmethod
    def _update(self, p: np.ndarray, g: np.ndarray) -> np.ndarray:
        """The rule itself; buffers are allocated and ``t`` already incremented."""

    def state_dict(self) -> dict[str, Any]:
        """Hyperparameters (floats), step count (int) and buffers (float arrays).

        Before the first step the buffers are empty arrays of shape ``(0,)``. Every value is a
        float, an int or a float64 array, so the dict can go to
        :func:`qdensity.learning.nn.save_parameters`.
        """
        state: dict[str, Any] = {name: float(getattr(self, name)) for name in self._hyper}
        state["t"] = int(self.t)
        for name in self._buffers:
            buf = getattr(self, name)
            state[name] = np.zeros(0) if buf is None else buf.copy()
        return state

    def load_state_dict(self, state: Mapping[str, Any]) -> None:
        """Restore hyperparameters, step count and buffers from :meth:`state_dict` output.

        Accepts the values back from ``.npz`` (0-d arrays) or JSON. Everything is validated
        before anything is changed.
        """
        if not isinstance(state, Mapping):
            raise TypeError(f"state must be a mapping, got {type(state).__name__}")
        want = set(self._hyper) | {"t"} | set(self._buffers)
        if set(state) != want:
            raise ValueError(
                f"state for {type(self).__name__} must have keys {sorted(want)}, "
                f"got {sorted(state)}"
            )
        probe = type(self).__new__(type(self))
        for name in self._hyper:
            setattr(probe, name, state[name])  # validates through the setters
        t = _check_step_int(state["t"], "state['t']")
        bufs = {}
        for name in self._buffers:
            bufs[name] = _check_vector(state[name], f"state[{name!r}]", None).copy()
        sizes = {b.size for b in bufs.values()}
        if len(sizes) > 1:
            raise ValueError(f"state buffers must have equal sizes, got {sorted(sizes)}")
        size = sizes.pop() if sizes else None
        if self._buffers and (t == 0) != (size == 0):
            raise ValueError(
                f"state['t'] = {t} does not match buffers of size {size} "
                "(empty buffers go with t = 0 only)"
            )
        for name in self._hyper:
            setattr(self, name, getattr(probe, name))
        self.t = t
        for name, buf in bufs.items():
            setattr(self, name, None if t == 0 else buf)
        self._size = None if (t == 0 or size is None) else size

    def __repr__(self) -> str:
        hyper = ", ".join(f"{n}={getattr(self, n)!r}" for n in self._hyper)
        return f"{type(self).__name__}({hyper})"


class SGD(Optimizer):
    r"""Stochastic gradient descent with optional heavy-ball momentum.

    ``v <- mu v + g``, ``params <- params - lr v`` (``v = 0`` before the first step), the
    convention of ``torch.optim.SGD``; for a constant ``lr`` it equals the textbook form
    ``u <- mu u - lr g``, ``params <- params + u``. With ``momentum = 0`` this is
    ``params - lr g``.

    Parameters
    ----------
    lr : float
        Learning rate, ``> 0``.
    momentum : float
        ``mu`` in ``[0, 1)``.

    Examples
    --------
    A constant gradient 1: ``v = 1`` then ``v = 0.9 + 1``, so the second step moves 0.19:

    >>> from qdensity.learning.optim import SGD
    >>> opt = SGD(lr=0.1, momentum=0.9)
    >>> p = opt.step([0.0], [1.0]); opt.step(p, [1.0])
    array([-0.29])
    """

    _hyper = ("lr", "momentum")
    _buffers = ("velocity",)
    velocity: np.ndarray  # allocated by step()

    def __init__(self, lr: float, momentum: float = 0.0) -> None:
        self.momentum = momentum
        super().__init__(lr)

    @property
    def momentum(self) -> float:
        return self._momentum

    @momentum.setter
    def momentum(self, value: float) -> None:
        self._momentum = _check_real(value, "momentum", low=0.0, high=1.0)

    def _update(self, p: np.ndarray, g: np.ndarray) -> np.ndarray:
        self.velocity = self.momentum * self.velocity + g
        return p - self.lr * self.velocity


class RMSprop(Optimizer):
    r"""RMSprop (Tieleman & Hinton 2012): ``s <- rho s + (1 - rho) g^2``,
    ``params <- params - lr g / (sqrt(s) + eps)``, as ``torch.optim.RMSprop`` without
    momentum or centring.

    Parameters
    ----------
    lr : float
        Learning rate, ``> 0``.
    rho : float
        Decay of the squared-gradient average, in ``[0, 1)``.
    eps : float
        ``> 0``, added to ``sqrt(s)``.

    Examples
    --------
    The first step moves every parameter by ``lr / sqrt(1 - rho)`` against its gradient's sign
    (up to ``eps``), here ``2 lr``:

    >>> from qdensity.learning.optim import RMSprop
    >>> RMSprop(lr=0.01, rho=0.75).step([1.0, -2.0], [0.5, -3.0])
    array([ 0.98, -1.98])
    """

    _hyper = ("lr", "rho", "eps")
    _buffers = ("square_avg",)
    square_avg: np.ndarray  # allocated by step()

    def __init__(self, lr: float = 1e-2, rho: float = 0.99, eps: float = 1e-8) -> None:
        self.rho = rho
        self.eps = eps
        super().__init__(lr)

    @property
    def rho(self) -> float:
        return self._rho

    @rho.setter
    def rho(self, value: float) -> None:
        self._rho = _check_real(value, "rho", low=0.0, high=1.0)

    @property
    def eps(self) -> float:
        return self._eps

    @eps.setter
    def eps(self, value: float) -> None:
        self._eps = _check_real(value, "eps", low=0.0, low_open=True)

    def _update(self, p: np.ndarray, g: np.ndarray) -> np.ndarray:
        self.square_avg = self.rho * self.square_avg + (1.0 - self.rho) * g * g
        return p - self.lr * g / (np.sqrt(self.square_avg) + self.eps)


class Adam(Optimizer):
    r"""Adam (Kingma & Ba 2015, Algorithm 1), the optimiser of the paper's experiments.

    With ``t`` the step count (1 on the first step)::

        m <- beta1 m + (1 - beta1) g
        v <- beta2 v + (1 - beta2) g^2
        m_hat = m / (1 - beta1^t),   v_hat = v / (1 - beta2^t)
        params <- params - lr m_hat / (sqrt(v_hat) + eps)

    Parameters
    ----------
    lr : float
        Learning rate, ``> 0`` (the paper uses 0.001).
    betas : tuple of float
        ``(beta1, beta2)``, each in ``[0, 1)``.
    eps : float
        ``> 0``.

    Examples
    --------
    >>> import numpy as np
    >>> from qdensity.learning.optim import Adam
    >>> Adam(lr=0.1).step(np.array([1.0, -2.0]), np.array([0.5, -1.0]))  # first step ~ lr*sign
    array([ 0.9, -1.9])
    """

    _hyper = ("lr", "beta1", "beta2", "eps")
    _buffers = ("m", "v")
    m: np.ndarray  # allocated by step()
    v: np.ndarray

    def __init__(
        self, lr: float = 1e-3, betas: tuple[float, float] = (0.9, 0.999), eps: float = 1e-8
    ) -> None:
        if not isinstance(betas, (tuple, list)) or len(betas) != 2:
            raise TypeError(f"betas must be a pair (beta1, beta2), got {betas!r}")
        self.beta1, self.beta2 = betas
        self.eps = eps
        super().__init__(lr)

    @property
    def betas(self) -> tuple[float, float]:
        return (self.beta1, self.beta2)

    @property
    def beta1(self) -> float:
        return self._beta1

    @beta1.setter
    def beta1(self, value: float) -> None:
        self._beta1 = _check_real(value, "betas[0]", low=0.0, high=1.0)

    @property
    def beta2(self) -> float:
        return self._beta2

    @beta2.setter
    def beta2(self, value: float) -> None:
        self._beta2 = _check_real(value, "betas[1]", low=0.0, high=1.0)

    @property
    def eps(self) -> float:
        return self._eps

    @eps.setter
    def eps(self, value: float) -> None:
        self._eps = _check_real(value, "eps", low=0.0, low_open=True)

    def _update(self, p: np.ndarray, g: np.ndarray) -> np.ndarray:
        b1, b2 = self.beta1, self.beta2
        self.m = b1 * self.m + (1.0 - b1) * g
        self.v = b2 * self.v + (1.0 - b2) * g * g
        m_hat = self.m / (1.0 - b1**self.t)
        v_hat = self.v / (1.0 - b2**self.t)
        return p - self.lr * m_hat / (np.sqrt(v_hat) + self.eps)

    def __repr__(self) -> str:
        return f"Adam(lr={self.lr!r}, betas={self.betas!r}, eps={self.eps!r})"
