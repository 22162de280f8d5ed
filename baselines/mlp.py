"""Data-driven RUL baseline (paper 2.2): an MLP from one event's measurements to the RUL.

Inputs, per event: the event index since installation, stopping distance, kinetic energy,
slope and brake temperature (paper 2.2's ``x = [N, d, E, theta, T]``; our logs carry the
mean event temperature). Each is standardised with the training set's mean and standard
deviation; a missing reading (sensor dropout, NaN) becomes the training mean. The target
is the true RUL of each training event, scaled by its training standard deviation. Two
hidden layers of 20 and 10 ReLU units, one linear output, mean-squared error, Adam with a
cosine-decaying learning rate over minibatches of the ~1e6 training events, on the CPU.

Training runs removed before failure (docs/results/prognostics.md) enter as what they are: after
event ``k`` of a run removed after event ``c``, the RUL is at least ``c + 1 - k``, so only
an estimate below that bound is an error (a one-sided squared loss, censored regression);
their measured volumes are not used. The event index counts from installation, so a log
that starts mid-life is read as it is.

Deterministic for a seed: the weights are initialised and the minibatches shuffled from one
``torch.Generator``. Predictions run in numpy (float64) with a fixed order of summation, so
an event's estimate is the same whatever the batch it arrives in and whatever the other
pads of a fleet. Saved without pickle: :meth:`MLPPredictor.get_state` gives the weights as
numpy arrays and the standardisation and config as JSON settings
(:mod:`brake_env.prognostics.persist`). This module is the only one of the package that
imports torch.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import pandas as pd
import torch
from numpy.typing import NDArray
from torch import nn

from baselines._runs import rul_targets, training_runs
from brake_env._validate import check_positive, check_state, from_dict
from brake_env.prognostics.fleet import RowFleet
from brake_env.prognostics.protocol import EventBatch, Predictor, RULEstimate

F64 = NDArray[np.float64]
FEATURES = ("event", "stop_dist_m", "energy_j", "slope_rad", "temp_c")
STATE_VERSION = 2
_PREDICT_CHUNK = 1 << 15


@dataclass(frozen=True)
class MLPConfig:
    """Network and training of the data-driven baseline.

    Attributes:
        hidden: Units of each hidden layer (the paper: 20 and 10).
        epochs: Passes over the training events.
        batch_size: Events per gradient step.
        learning_rate: Initial Adam step size; it decays to 0 along a cosine [-].
        weight_decay: L2 penalty of Adam [-].
        seed: Seed of weight initialisation and minibatch shuffling.
        threads: Torch CPU threads while fitting and predicting (restored after).
    """

    hidden: tuple[int, ...] = (20, 10)
    epochs: int = 8
    batch_size: int = 512
    learning_rate: float = 3e-3
    weight_decay: float = 0.0
    seed: int = 0
    threads: int = 1

    def __post_init__(self) -> None:
        object.__setattr__(self, "hidden", tuple(self.hidden))
        if not self.hidden or not all(isinstance(h, int) and h > 0 for h in self.hidden):
            raise ValueError(f"MLPConfig.hidden must be positive ints, got {self.hidden!r}")
        for name in ("epochs", "batch_size", "threads"):
            n = getattr(self, name)
            if not isinstance(n, int) or n < 1:
                raise ValueError(f"MLPConfig.{name} must be an int >= 1, got {n!r}")
        check_positive(self, "learning_rate")
        if not self.weight_decay >= 0:
            raise ValueError(f"MLPConfig.weight_decay must be >= 0, got {self.weight_decay}")
        if not isinstance(self.seed, int):
            raise ValueError(f"MLPConfig.seed must be an int, got {self.seed!r}")


def build_network(n_in: int, hidden: tuple[int, ...], generator: torch.Generator) -> nn.Sequential:
    """ReLU layers ``n_in -> hidden... -> 1``, initialised like ``nn.Linear`` from ``generator``."""
    layers: list[nn.Module] = []
    sizes = (n_in, *hidden, 1)
    for a, b in itertools.pairwise(sizes):
        lin = nn.Linear(a, b, dtype=torch.float32)
        # nn.Linear's default init (Kaiming-uniform, a = sqrt(5)) but from our generator,
        # not the global one: U(-1/sqrt(fan_in), 1/sqrt(fan_in)) for weights and biases.
        bound = 1.0 / math.sqrt(a)
        with torch.no_grad():
            lin.weight.uniform_(-bound, bound, generator=generator)
            lin.bias.uniform_(-bound, bound, generator=generator)
        layers += [lin, nn.ReLU()]
    return nn.Sequential(*layers[:-1])


def features(events: EventBatch | pd.DataFrame) -> F64:
    """The input matrix (events x FEATURES), unstandardised; NaN where a reading is missing."""
    cols = [
        np.asarray(getattr(events, f) if isinstance(events, EventBatch) else events[f])
        for f in FEATURES
    ]
    return np.stack([c.astype(np.float64) for c in cols], axis=1)


class MLPPredictor(Predictor):
    """Direct RUL regression from one event's measurements (paper 2.2).

    Args:
        config: Network and training options.

    Attributes:
        x_mean, x_std: Standardisation of the inputs, from the training events.
        y_scale: Standard deviation of the training RUL; the network predicts RUL / y_scale.
        loss_history: Mean training loss of each epoch (on the scaled target).
        fit_seconds: Wall time of the last fit.
    """

    name = "data"
    kept_by_evaluate = True  # its weights: a random, costly fit

    def __init__(self, config: MLPConfig | None = None) -> None:
        super().__init__()
        self.config = config or MLPConfig()
        self.net: nn.Sequential | None = None
        self._layers: list[tuple[F64, F64]] = []  # (weight, bias) of each layer, float64
        self.x_mean: F64 | None = None
        self.x_std: F64 | None = None
        self.y_scale = 1.0
        self.loss_history: list[float] = []
        self.fit_seconds = 0.0
        self.progress: Callable[[int], object] | None = None

    # ---------------------------------------------------------------- training
    def _fit(self, train_log: pd.DataFrame) -> None:
        t0 = time.perf_counter()
        x = features(train_log)
        y, censored = rul_targets(train_log)
        if len(y) < 2:
            raise ValueError("data: the training log needs at least two events")
        if censored.all():
            runs = training_runs(train_log)
            raise ValueError(
                f"data: every training run ({runs.describe(runs.censored)}) was removed before"
                " failure; the MLP needs runs whose life is known"
            )
        self.x_mean = np.nanmean(x, axis=0)
        std = np.nanstd(x, axis=0)
        self.x_std = np.where(std > 0, std, 1.0)
        self.y_scale = float(np.std(y)) or 1.0
        xs = torch.from_numpy(self._standardise(x).astype(np.float32))
        ys = torch.from_numpy((y / self.y_scale).astype(np.float32))[:, None]
        lower = torch.from_numpy(censored)[:, None] if censored.any() else None
        threads = torch.get_num_threads()
        torch.set_num_threads(self.config.threads)
        try:
            net = self._train(xs, ys, lower)
        finally:
            torch.set_num_threads(threads)
        self._set_network(net)
        self.fit_seconds = time.perf_counter() - t0

    def _train(
        self, xs: torch.Tensor, ys: torch.Tensor, lower: torch.Tensor | None
    ) -> nn.Sequential:
        """Adam over shuffled minibatches; where ``lower`` is true the target is a lower
        bound, and only an estimate below it counts as an error."""
        cfg = self.config
        g = torch.Generator().manual_seed(cfg.seed)
        net = build_network(len(FEATURES), cfg.hidden, g)
        opt = torch.optim.Adam(
            net.parameters(), lr=cfg.learning_rate, weight_decay=cfg.weight_decay
        )
        n = len(ys)
        steps_per_epoch = math.ceil(n / cfg.batch_size)
        sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=cfg.epochs * steps_per_epoch)
        loss_fn = nn.MSELoss()
        self.loss_history = []
        for _ in range(cfg.epochs):
            perm = torch.randperm(n, generator=g)
            total = 0.0
            for i in range(steps_per_epoch):
                idx = perm[i * cfg.batch_size : (i + 1) * cfg.batch_size]
                opt.zero_grad(set_to_none=True)
                if lower is None:
                    loss = loss_fn(net(xs[idx]), ys[idx])
                else:
                    err = net(xs[idx]) - ys[idx]
                    loss = torch.where(lower[idx], err.clamp(max=0.0), err).square().mean()
                loss.backward()
                opt.step()
                sched.step()
                total += float(loss.detach()) * len(idx)
            self.loss_history.append(total / n)
            if self.progress:
                self.progress(1)
        return net

    def _standardise(self, x: F64) -> F64:
        assert self.x_mean is not None and self.x_std is not None
        z = (x - self.x_mean) / self.x_std
        return np.nan_to_num(z, nan=0.0)  # missing reading -> the mean

    def _set_network(self, net: nn.Sequential) -> None:
        self.net = net.eval()
        lins = [m for m in net if isinstance(m, nn.Linear)]
        self._layers = [
            (
                m.weight.detach().numpy().astype(np.float64),
                m.bias.detach().numpy().astype(np.float64),
            )
            for m in lins
        ]

    # ---------------------------------------------------------------- prediction
    def predict(self, x: F64) -> F64:
        """RUL [events] for raw input rows (events x FEATURES), floored at 0.

        Each row's sums run in a fixed order, so its estimate does not depend on the rows
        it is computed with (batch sizes, other pads).
        """
        if not self._layers:
            raise RuntimeError("data: call fit() or set_state() before predicting")
        z = self._standardise(np.asarray(x, dtype=np.float64))
        out = np.empty(len(z))
        last = len(self._layers) - 1
        for i in range(0, len(z), _PREDICT_CHUNK):
            h = z[i : i + _PREDICT_CHUNK]
            for j, (w, b) in enumerate(self._layers):
                acc = np.repeat(b[None, :], len(h), axis=0)
                for k in range(w.shape[1]):
                    acc += h[:, k : k + 1] * w[:, k]
                h = acc if j == last else np.maximum(acc, 0.0)
            out[i : i + len(h)] = h[:, 0]
        return np.maximum(out * self.y_scale, 0.0)

    def _update(self, events: EventBatch) -> RULEstimate:
        return RULEstimate(rul_mean=self.predict(features(events)))

    def fleet(self, n_pads: int) -> RowFleet:
        """All pads in one forward pass over the wanted rows (an estimate is per event)."""
        if not self._layers:
            raise RuntimeError("data: call fit() or set_state() before making a fleet")
        return RowFleet(self.name, n_pads, self._at_rows)

    def _at_rows(self, events: EventBatch, want: NDArray[np.bool_]) -> RULEstimate:
        return RULEstimate(rul_mean=self.predict(features(events)[want]))

    # ---------------------------------------------------------------- state
    def get_state(self) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
        """Config, standardisation and training record as settings; the network's
        ``state_dict`` as float32 arrays ``net.<name>``."""
        if self.net is None or self.x_mean is None or self.x_std is None:
            raise RuntimeError("data: nothing to save, the network is not fitted")
        meta: dict[str, Any] = {
            "state_version": STATE_VERSION,
            "features": list(FEATURES),
            "x_mean": self.x_mean.tolist(),
            "x_std": self.x_std.tolist(),
            "y_scale": self.y_scale,
            "config": {**asdict(self.config), "hidden": list(self.config.hidden)},
            "loss_history": self.loss_history,
            "fit_seconds": self.fit_seconds,
        }
        arrays = {f"net.{k}": v.detach().cpu().numpy() for k, v in self.net.state_dict().items()}
        return meta, arrays

    def set_state(self, meta: Mapping[str, Any], arrays: Mapping[str, NDArray[Any]]) -> None:
        """Rebuild the network from :meth:`get_state`'s output (no ``torch.load``)."""
        if meta.get("state_version") != STATE_VERSION or meta.get("features") != list(FEATURES):
            raise ValueError(
                f"data: not a version-{STATE_VERSION} MLP state of features {list(FEATURES)}"
            )
        check_state(
            "data",
            meta,
            {},
            meta_keys=("state_version", "features", "x_mean", "x_std", "y_scale", "config"),
            optional_meta=("loss_history", "fit_seconds"),
            finite=("x_mean", "x_std", "y_scale"),
        )
        check_state("data", {}, arrays, optional_arrays=arrays, finite=arrays)
        if not isinstance(meta["config"], dict) or "hidden" not in meta["config"]:
            raise ValueError("data: the saved setting 'config' is not an MLP config; refit")
        cfg = from_dict(MLPConfig, {**meta["config"], "hidden": tuple(meta["config"]["hidden"])})
        net = build_network(len(FEATURES), cfg.hidden, torch.Generator().manual_seed(0))
        want = set(net.state_dict())
        got = {k.removeprefix("net."): v for k, v in arrays.items() if k.startswith("net.")}
        if set(got) != want:
            raise ValueError(f"data: state arrays {sorted(got)} do not fit layers {sorted(want)}")
        state = {
            k: torch.from_numpy(np.asarray(v, dtype=np.float32).copy()) for k, v in got.items()
        }
        net.load_state_dict(state)  # shapes checked by torch
        self.config = cfg
        self.x_mean = np.asarray(meta["x_mean"], dtype=np.float64)
        self.x_std = np.asarray(meta["x_std"], dtype=np.float64)
        self.y_scale = float(meta["y_scale"])
        self.loss_history = [float(v) for v in meta.get("loss_history", [])]
        self.fit_seconds = float(meta.get("fit_seconds", 0.0))
        self._set_network(net)


def make_mlp(atlas: object, seed: int = 0) -> MLPPredictor:
    """Registry factory (``brakewear.predictors``): the paper's MLP, seeded."""
    return MLPPredictor(MLPConfig(seed=seed))
