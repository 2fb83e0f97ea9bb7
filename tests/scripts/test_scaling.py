"""bench/scaling.py's layered scene: at 50 layers it is configs/benchmarks/layers50_cylinder.yaml
(the benchmark the scaling extends), and smaller sizes keep its parameters and spacing."""
import importlib.util
import os
import pathlib

import yaml

ROOT = pathlib.Path(os.environ.get("CCFR_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
spec = importlib.util.spec_from_file_location("scaling", ROOT / "bench" / "scaling.py")
scaling = importlib.util.module_from_spec(spec)
spec.loader.exec_module(scaling)


def test_fifty_layers_are_the_benchmark_config():
    ours = yaml.safe_load(scaling.layers_yaml(245000))
    config = yaml.safe_load((ROOT / "configs" / "benchmarks" / "layers50_cylinder.yaml").read_text())
    assert ours == config


def test_sizes_round_to_whole_layers_with_the_same_spacing():
    five = yaml.safe_load(scaling.layers_yaml(24000))
    config = yaml.safe_load((ROOT / "configs" / "benchmarks" / "layers50_cylinder.yaml").read_text())
    layers = [o for o in five["objects"] if o["kind"] == "cloth"]
    assert len(layers) == 5
    assert five["scene"] == "layers5_cylinder"
    assert layers == [o for o in config["objects"] if o["kind"] == "cloth"][:5]
    assert {k: v for k, v in five.items() if k not in ("objects", "scene")} == \
           {k: v for k, v in config.items() if k not in ("objects", "scene")}
