"""The cluster documentation works as written: the Ray cluster config passes Ray's own
schema, and every brakewear command in docs/cluster.md parses."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def test_the_cluster_config_passes_rays_schema():
    ray = pytest.importorskip("ray")
    jsonschema = pytest.importorskip("jsonschema")
    yaml = pytest.importorskip("yaml")
    schema_path = Path(ray.__file__).parent / "autoscaler" / "ray-schema.json"
    schema = json.loads(schema_path.read_text())
    config = yaml.safe_load((ROOT / "docs" / "ray-cluster.yaml").read_text())
    jsonschema.validate(config, schema)
    assert config["provider"]["type"] == "local"
    with pytest.raises(jsonschema.ValidationError):  # the check can fail
        jsonschema.validate({**config, "min_workers": 3}, schema)


def doc_commands() -> list[list[str]]:
    text = (ROOT / "docs" / "cluster.md").read_text()
    lines = [ln.strip() for ln in text.splitlines() if ln.strip().startswith("brakewear ")]
    return [shlex.split(ln.split(" #", 1)[0])[1:] for ln in lines]


def test_every_command_in_the_cluster_page_parses():
    from brake_env.cli.main import build_parser

    commands = doc_commands()
    assert len(commands) >= 4 and all("--ray" in c or "--workers" in c for c in commands)
    parser = build_parser()
    for argv in commands:
        args = parser.parse_args(argv)
        assert hasattr(args, "ray") and hasattr(args, "workers"), argv
