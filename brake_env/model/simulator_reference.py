"""The literal per-event simulation loop (paper Steps 3-5 as written), kept to test the
vectorised :func:`brake_env.model.simulator.simulate_runs` against and as the benchmark
baseline: one atlas query per event, over the same random stream."""

from __future__ import annotations

import numpy as np

from brake_env.model.atlas import Atlas
from brake_env.model.simulator import (
    RESPONSE_FIELDS,
    AlternatingRoutes,
    ConditionStream,
    Trajectory,
    check_wear_per_event,
    conditions_from_uniform,
)


def simulate_run_reference(
    atlas: Atlas,
    wear_coeff: float,
    seed: np.random.SeedSequence,
    interpolate_layers: bool = False,
    duty: AlternatingRoutes | None = None,
) -> Trajectory:
    """Literal per-event loop over the same random stream as :func:`simulate_runs` (with
    the same ``duty``, if any).

    The reference for tests and the benchmark baseline: one atlas query per event.
    """
    check_wear_per_event(atlas, wear_coeff)
    pad_v = atlas.spec.model.brake.pad_volume_m3
    stream = ConditionStream(np.random.default_rng(seed), duty=duty)
    lowers = atlas.lower_edges
    rows = []
    j, vol, k = 0, 1.0, 0
    layer_start, acc = 1.0, 0.0
    while True:
        s, m, th = conditions_from_uniform(atlas, stream.take(k, 1)[0])
        r = atlas.query(s, m, th, layer=np.int64(j), fields=RESPONSE_FIELDS)
        if interpolate_layers and j + 1 < atlas.n_layers:
            # Blend with the next layer by the depth of the current volume into this one.
            w = (atlas.volumes[j] - vol) / atlas.spec.layer_step
            r2 = atlas.query(s, m, th, layer=np.int64(j + 1), fields=RESPONSE_FIELDS)
            r = {f: (1.0 - w) * r[f] + w * r2[f] for f in RESPONSE_FIELDS}
        dv = wear_coeff * r["wear_per_k_m3"] / pad_v
        acc += float(dv)  # accumulate like a cumulative sum within the layer
        after = layer_start - acc
        rows.append((s, m, th, float(r["temp_mean_c"]), float(r["stop_dist_m"]), float(dv), vol, j))
        vol, k = after, k + 1
        if after <= lowers[j]:
            if after <= lowers[-1]:
                break  # end of life
            while after <= lowers[j]:  # the next layer whose band holds the volume
                j += 1
            layer_start, acc = after, 0.0
    sp, m, th, temp, dist, dv, v, lay = (np.array(c) for c in zip(*rows, strict=True))
    return Trajectory(
        float(wear_coeff), sp, m, th, temp, dist, dv, v, lay.astype(np.int16), float(vol)
    )
