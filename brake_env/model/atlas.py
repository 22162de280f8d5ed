"""The brake performance atlas: one lookup map per 1% of pad volume (paper 2.1.2).

Each layer holds the physics of ``brake_env.model.physics`` evaluated on a regular grid over speed,
mass and slope. Queries interpolate trilinearly inside a layer; across layers they either use
the active layer (the paper's Step 3) or interpolate linearly in volume (its footnote 1).
Atlases are saved as ``.npz`` without pickle, identified by a hash of everything that
determines their content, and cached on disk under that hash.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import time
import zipfile
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from brake_env._validate import plain_numbers
from brake_env.model.effects import resolve_effects
from brake_env.model.lookup import GridLookup, trapezoid_weights
from brake_env.model.params import BrakeModel
from brake_env.model.physics import critical_volume, end_of_life, simulate_events

F64 = NDArray[np.float64]
FORMAT_VERSION = 2
# Bump whenever brake_env.model.physics or brake_env.model.materials change what they compute: the
# version is hashed with the parameters, so cached atlases of older physics are not reused.
PHYSICS_VERSION = 3
_LAYERS_PER_CHUNK = 8
FIELDS = (
    "temp_mean_c",
    "temp_peak_c",
    "stop_dist_m",
    "sliding_dist_m",
    "stop_time_s",
    "wear_per_k_m3",
)


@dataclass(frozen=True)
class AtlasSpec:
    """What determines an atlas: the physics and the grid.

    Attributes:
        model: Physical parameters of vehicle and brake.
        n_speed: Grid nodes over the speed range [-] (default: every 0.5 km/h).
        n_mass: Grid nodes over the mass range [-] (default: every 2 t).
        n_slope: Grid nodes over the slope range [-] (default: every 0.5 deg).
        layer_step: Pad-volume fraction between layers [-] (the paper: 1%).
        effects: Unmodelled effects built into the physics, as canonical text
            ``NAME:P=V,...`` (:mod:`brake_env.model.effects`); empty: the nominal physics.
    """

    model: BrakeModel = field(default_factory=BrakeModel)
    n_speed: int = 23
    n_mass: int = 7
    n_slope: int = 21
    layer_step: float = 0.01
    effects: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if isinstance(self.effects, list):  # from JSON
            object.__setattr__(self, "effects", tuple(self.effects))
        if not isinstance(self.effects, tuple) or not all(
            isinstance(e, str) and e.strip() for e in self.effects
        ):
            raise ValueError(
                f"AtlasSpec.effects must be a tuple of effect texts, got {self.effects!r}"
            )
        plain_numbers(self)
        for name in ("n_speed", "n_mass", "n_slope"):
            n = getattr(self, name)
            if not isinstance(n, int) or not 2 <= n <= 200:
                raise ValueError(f"AtlasSpec.{name} must be an int in [2, 200], got {n!r}")
        if not 0.001 <= self.layer_step <= 0.2:
            raise ValueError(f"AtlasSpec.layer_step must be in [0.001, 0.2], got {self.layer_step}")

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> AtlasSpec:
        data = dict(data)
        model = BrakeModel.from_dict(data.pop("model", {}))
        return cls(model=model, **data)

    def content_hash(self) -> str:
        """SHA-256 of the spec (its effects included), the physics version and the file
        format version. A nominal spec hashes as before effects existed, so its cached
        atlases and saved models stay valid."""
        spec = self.to_dict()
        if not spec["effects"]:
            del spec["effects"]
        payload = json.dumps(
            {"format": FORMAT_VERSION, "physics": PHYSICS_VERSION, "spec": spec}, sort_keys=True
        )
        return hashlib.sha256(payload.encode()).hexdigest()


@dataclass(frozen=True, eq=False)
class Atlas:
    """Layers of braking response over (speed, mass, slope), from a fresh pad down to failure.

    Attributes:
        spec: What the atlas was built from.
        volumes: Pad volume fraction of each layer, 1.0 first, decreasing [-].
        speed_mps, mass_kg, slope_rad: Grid axes.
        fields: Name -> array of shape (layers, n_speed, n_mass, n_slope); see ``FIELDS``.
        critical_volume: Volume fraction below which the severe event cannot stop, from the
            physics; 0.0 if it always stops [-].
        build_seconds: Wall time of the build (kept in the file, so also after loading).
    """

    spec: AtlasSpec
    volumes: F64
    speed_mps: F64
    mass_kg: F64
    slope_rad: F64
    fields: dict[str, F64]
    critical_volume: float
    build_seconds: float = 0.0

    # ---------------------------------------------------------------- construction
    @classmethod
    def build(
        cls,
        spec: AtlasSpec | None = None,
        progress: Callable[[int], object] | None = None,
    ) -> Atlas:
        """Evaluate the physics on every grid node of every layer, vectorised.

        Layers go in chunks of ``_LAYERS_PER_CHUNK`` (cache-sized arrays); ``progress`` is
        called with the number of layers finished after each chunk. The spec's effects
        (:mod:`brake_env.model.effects`) change the in-event physics, and a sensor effect
        what the logged mean temperature is; both are in the spec, so in the hash.
        """
        spec = spec or AtlasSpec()
        t0 = time.perf_counter()
        effects = resolve_effects(spec.effects, spec.model)
        modifier = effects.modifier
        env = spec.model.envelope
        speed = np.linspace(*env.speed_kmh, spec.n_speed) / 3.6
        mass = np.linspace(*env.mass_kg, spec.n_mass)
        slope = np.radians(np.linspace(*env.slope_deg, spec.n_slope))
        v_crit = critical_volume(spec.model, modifier=modifier)
        v_end = end_of_life(v_crit, spec.model)
        n_layers = int(np.floor((1.0 - v_end) / spec.layer_step + 1e-9)) + 1
        volumes = (1.0 - spec.layer_step * np.arange(n_layers)).astype(np.float64)
        volumes = volumes[volumes > v_end]
        fields = {
            name: np.empty((volumes.size, speed.size, mass.size, slope.size)) for name in FIELDS
        }
        for lo in range(0, volumes.size, _LAYERS_PER_CHUNK):
            hi = min(lo + _LAYERS_PER_CHUNK, volumes.size)
            resp = simulate_events(
                speed[None, :, None, None],
                mass[None, None, :, None],
                slope[None, None, None, :],
                volumes[lo:hi, None, None, None],
                spec.model,
                modifier=modifier,
            )
            if not resp.stopped.all():
                bad = tuple(int(x) for x in np.argwhere(~resp.stopped)[0] + [lo, 0, 0, 0])
                raise RuntimeError(
                    f"grid event {bad} (layer, speed, mass, slope) does not stop above the critical"
                    f" volume {v_crit:.4f}: the severe corner is not the worst case of this model"
                )
            for name in FIELDS:
                fields[name][lo:hi] = getattr(resp, name)
            if progress:
                progress(hi - lo)
        effects.apply_sensor(fields, spec.model.brake.start_temp_c)
        return cls(spec, volumes, speed, mass, slope, fields, v_crit, time.perf_counter() - t0)

    @property
    def failure_volume(self) -> float:
        """End of pad life: the critical volume, or the wear-out limit if that is higher."""
        return end_of_life(self.critical_volume, self.spec.model)

    @property
    def lower_edges(self) -> F64:
        """Volume at which each layer hands over to the next; the last one's is end of life."""
        return np.append(self.volumes[1:], self.failure_volume)

    @property
    def failure_mode(self) -> str:
        """``cannot-stop`` (the severe event fails) or ``worn-out`` (the wear-out limit)."""
        return "cannot-stop" if self.failure_volume == self.critical_volume else "worn-out"

    # ---------------------------------------------------------------- persistence
    @property
    def content_hash(self) -> str:
        return self.spec.content_hash()

    @property
    def n_layers(self) -> int:
        return int(self.volumes.size)

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write an ``.npz`` (no pickled objects); the spec travels as JSON text."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        meta = {
            "format": FORMAT_VERSION,
            "hash": self.content_hash,
            "spec": self.spec.to_dict(),
            "critical_volume": self.critical_volume,
            "build_seconds": self.build_seconds,
        }
        # A name of its own per process: parallel workers may build the same atlas at once.
        tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp.npz")
        arrays = self._arrays()
        meta["arrays_sha256"] = _digest(arrays)
        payload: dict[str, Any] = {"meta": np.array(json.dumps(meta, sort_keys=True)), **arrays}
        np.savez_compressed(tmp, **payload)
        tmp.replace(path)  # atomic: a concurrent reader never sees half a file
        return path

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Atlas:
        """Read an atlas written by :meth:`save`.

        Checks the format, that the parameters match their hash, that the arrays match
        their checksum and the grid of the parameters; raises ValueError otherwise.
        """
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            if meta.get("format") != FORMAT_VERSION:
                raise ValueError(
                    f"{path}: atlas format {meta.get('format')}, expected {FORMAT_VERSION}"
                )
            spec = AtlasSpec.from_dict(meta["spec"])
            if spec.content_hash() != meta["hash"]:
                raise ValueError(
                    f"{path}: parameters or physics version do not match the stored hash"
                )
            arrays = {k: z[k] for k in z.files if k != "meta"}
        if _digest(arrays) != meta.get("arrays_sha256"):
            raise ValueError(f"{path}: arrays do not match their checksum (corrupt or edited)")
        fields = {k: arrays[f"field_{k}"] for k in FIELDS}
        grid = (spec.n_speed, spec.n_mass, spec.n_slope)
        if any(f.shape != (arrays["volumes"].size, *grid) for f in fields.values()):
            raise ValueError(f"{path}: field shapes do not match {arrays['volumes'].size} x {grid}")
        return cls(
            spec,
            arrays["volumes"],
            arrays["speed_mps"],
            arrays["mass_kg"],
            arrays["slope_rad"],
            fields,
            float(meta["critical_volume"]),
            float(meta.get("build_seconds", 0.0)),
        )

    def _arrays(self) -> dict[str, F64]:
        return {
            "volumes": self.volumes,
            "speed_mps": self.speed_mps,
            "mass_kg": self.mass_kg,
            "slope_rad": self.slope_rad,
            **{f"field_{k}": v for k, v in self.fields.items()},
        }

    # ---------------------------------------------------------------- queries
    @cached_property
    def lookup(self) -> GridLookup:
        """The trilinear lookup on this atlas's grid (:mod:`brake_env.model.lookup`)."""
        return GridLookup((self.speed_mps, self.mass_kg, self.slope_rad), self.fields)

    def layer_of(self, volume_frac: ArrayLike) -> NDArray[np.intp]:
        """Index of the active layer: the map at the lowest 1% level at or above the volume."""
        v = np.asarray(volume_frac, dtype=np.float64)
        self._check_volume(v)
        j = np.floor((1.0 - v) / self.spec.layer_step + 1e-9).astype(np.intp)
        return np.clip(j, 0, self.n_layers - 1)

    def query(
        self,
        speed_mps: ArrayLike,
        mass_kg: ArrayLike,
        slope_rad: ArrayLike,
        *,
        layer: ArrayLike | None = None,
        volume_frac: ArrayLike | None = None,
        interpolate_layers: bool = False,
        fields: tuple[str, ...] = FIELDS,
        clip: bool = False,
    ) -> dict[str, F64]:
        """Braking response for a batch of conditions (inputs broadcast together).

        Give either ``layer`` (integer layer indices) or ``volume_frac``. With ``volume_frac``
        the active layer is used, or with ``interpolate_layers`` a linear blend of the two
        layers around it. Conditions outside the grid raise unless ``clip`` is set.
        """
        if (layer is None) == (volume_frac is None):
            raise ValueError("give exactly one of layer= or volume_frac=")
        unknown = set(fields) - set(FIELDS)
        if unknown:
            raise ValueError(f"unknown atlas field(s) {sorted(unknown)}; valid are {list(FIELDS)}")
        s, m, th = (np.asarray(x, dtype=np.float64) for x in (speed_mps, mass_kg, slope_rad))
        if layer is not None:
            lay = np.asarray(layer)
            if not np.issubdtype(lay.dtype, np.integer):
                raise TypeError("layer must be integer indices; use volume_frac= for fractions")
            if lay.size and (lay.min() < 0 or lay.max() >= self.n_layers):
                raise ValueError(f"layer must be in [0, {self.n_layers - 1}]")
            s, m, th, lay = np.broadcast_arrays(s, m, th, lay)
            cell, frac = self.lookup.locate(s, m, th, clip)
            return self.lookup.interp(tuple(fields), lay, cell, frac)

        vol = np.asarray(volume_frac, dtype=np.float64)
        s, m, th, vol = np.broadcast_arrays(s, m, th, vol)
        cell, frac = self.lookup.locate(s, m, th, clip)
        j0 = self.layer_of(vol)
        if not interpolate_layers:
            return self.lookup.interp(tuple(fields), j0, cell, frac)
        # Blend with the next (lower-volume) layer; the last layer has none and is held.
        j1 = np.minimum(j0 + 1, self.n_layers - 1)
        w1 = np.where(j1 > j0, (self.volumes[j0] - vol) / self.spec.layer_step, 0.0)
        a = self.lookup.interp(tuple(fields), j0, cell, frac)
        b = self.lookup.interp(tuple(fields), j1, cell, frac)
        return {f: (1.0 - w1) * a[f] + w1 * b[f] for f in fields}

    def expected(self, field_name: str, power: int = 1) -> F64:
        """Mean of a field (or of its ``power``) per layer under uniform operating conditions
        over the envelope; computed once per atlas, read-only.

        Exact for the trilinear interpolant (``power=1``): the uniform mean of a
        piecewise-trilinear function is the trapezoid-weighted mean of its node values.
        With ``power=2`` it is the same weighting of the squared node values (the spread of
        the field over the envelope, to within the interpolant's curvature).
        """
        cache = self.__dict__.setdefault("_expected", {})
        if (field_name, power) not in cache:
            f = self.fields[field_name]
            w = np.einsum("i,j,k->ijk", *(trapezoid_weights(n) for n in f.shape[1:]))
            mean = np.einsum("lijk,ijk->l", f if power == 1 else f**power, w)
            mean.flags.writeable = False  # shared by every caller
            cache[field_name, power] = mean
        return cache[field_name, power]

    # ---------------------------------------------------------------- internals
    def _check_volume(self, v: F64) -> None:
        if v.size and not np.all(np.isfinite(v)):
            raise ValueError("volume_frac must be finite (got NaN or inf)")
        if v.size and (v.max() > 1.0 + 1e-12 or v.min() < self.failure_volume):
            raise ValueError(
                f"volume_frac must be in [{self.failure_volume:.4f}, 1] (end of life to fresh),"
                f" got range [{v.min():g}, {v.max():g}]"
            )


def _digest(arrays: dict[str, np.ndarray]) -> str:
    """SHA-256 over the names, shapes and bytes of the arrays, in name order."""
    h = hashlib.sha256()
    for k in sorted(arrays):
        a = np.ascontiguousarray(arrays[k], dtype=np.float64)
        h.update(f"{k}{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def default_cache_dir() -> Path:
    """``$BRAKEWEAR_CACHE_DIR`` or ``~/.cache/brakewear``."""
    env = os.environ.get("BRAKEWEAR_CACHE_DIR")
    return Path(env) if env else Path.home() / ".cache" / "brakewear"


def cached_atlas(
    spec: AtlasSpec | None = None,
    cache_dir: str | os.PathLike[str] | None = None,
    rebuild: bool = False,
    progress: Callable[[int], object] | None = None,
) -> Atlas:
    """Load the atlas of ``spec`` from the cache, building and saving it on a miss."""
    spec = spec or AtlasSpec()
    path = Path(cache_dir or default_cache_dir()) / f"atlas-{spec.content_hash()[:16]}.npz"
    if path.exists() and not rebuild:
        try:
            atlas = Atlas.load(path)
            if atlas.content_hash == spec.content_hash():
                return atlas
        except (ValueError, KeyError, OSError, EOFError, zipfile.BadZipFile):
            pass  # stale or corrupt cache entry: rebuild it below
    atlas = Atlas.build(spec, progress)
    atlas.save(path)
    return atlas
