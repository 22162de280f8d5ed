"""The small, fast fleet the env tests share: 3 vehicles, pads wearing 5x faster than the
default (life ~2.4e4 events)."""

SMALL = {
    "n_vehicles": 3,
    "hot_need": 1,
    "mild_need": 1,
    "events_per_shift": 100,
    "episode_shifts": 60,
    "initial_age_max": 0.3,
    "k_mean": 1e-5,
    "k_std": 1e-6,
}
