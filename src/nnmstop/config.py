"""Loading and validating the pipeline configuration (``config/config.yaml``).

The JSON Schema lives beside this module (``config_schema.yaml``). Every error
names the offending key, for example ``config key 'model.alpha': -1.0 is less than
or equal to the minimum of 0``.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import jsonschema
import yaml

__all__ = ["ConfigError", "load_schema", "validate_config", "load_config"]


class ConfigError(ValueError):
    """A configuration value is missing, of the wrong type or out of range."""


def load_schema() -> dict:
    """The JSON Schema of the configuration, as a dict."""
    text = resources.files("nnmstop").joinpath("config_schema.yaml").read_text()
    return yaml.safe_load(text)


def _key_path(error: jsonschema.ValidationError) -> str:
    path = ".".join(str(p) for p in error.absolute_path)
    if error.validator == "additionalProperties":
        extra = sorted(set(error.instance) - set(error.schema.get("properties", {})))
        return ".".join(filter(None, [path, extra[0] if extra else ""]))
    if error.validator == "required":
        missing = [k for k in error.validator_value if k not in error.instance]
        return ".".join(filter(None, [path, missing[0] if missing else ""]))
    return path or "<root>"


def validate_config(config: dict) -> dict:
    """Check ``config`` against the schema and the cross-key rules; return it unchanged.

    Raises
    ------
    ConfigError
        Naming the first offending key and what is allowed there.
    """
    validator = jsonschema.Draft202012Validator(load_schema())
    errors = sorted(validator.iter_errors(config), key=lambda e: (len(e.absolute_path), str(e.absolute_path)))
    if errors:
        first = errors[0]
        raise ConfigError(f"config key '{_key_path(first)}': {first.message}")
    model = config["model"]
    if model["eta"] >= model["alpha"]:
        raise ConfigError(
            f"config key 'model.eta': {model['eta']} must be smaller than model.alpha = {model['alpha']} "
            "(the regularized force has no admissible branch otherwise)"
        )
    for name, spec in config.get("bifurcations", {}).items():
        stages = len(config["branches"][spec["parent"]]["stages"])
        if spec["stage"] > stages:
            raise ConfigError(
                f"config key 'bifurcations.{name}.stage': {spec['stage']} exceeds the {stages} stages of "
                f"branch {spec['parent']!r}"
            )
        low, high = spec["energy_range"]
        if not low < high:
            raise ConfigError(
                f"config key 'bifurcations.{name}.energy_range': {spec['energy_range']} must be increasing"
            )
    stability = config.get("stability", {})
    if stability.get("max_steps", 0) and stability.get("steps", 0) and stability["max_steps"] < stability["steps"]:
        raise ConfigError(
            f"config key 'stability.max_steps': {stability['max_steps']} must be >= stability.steps = "
            f"{stability['steps']}"
        )
    for figure, spec in config.get("figures", {}).items():
        unknown = [
            n
            for n in (spec.get("bifurcated", []) if isinstance(spec, dict) else [])
            if n not in config.get("bifurcations", {})
        ]
        if unknown:
            raise ConfigError(
                f"config key 'figures.{figure}.bifurcated': {unknown} not among the configured bifurcations "
                f"{sorted(config.get('bifurcations', {}))}"
            )
    if "tube" in config:
        _check_tube(config["tube"])
    if "forced" in config:
        _check_forced(config)
    return config


def _check_forced(config: dict) -> None:
    """Frequency ranges increasing, force DOFs on the model (nnmstop.tasks.forced builds the scenes)."""
    from nnmstop.forced.scenes import forced_scenes

    try:
        forced_scenes(config)
    except (TypeError, ValueError) as err:
        raise ConfigError(f"config key 'forced': {err}") from None


def _check_tube(tube: dict) -> None:
    """The tube's structure must make a beam (stops on nodes, eta below the stop stiffness, ...)."""
    from nnmstop.models.beam import Beam

    try:
        beam = Beam.from_parameters(tube["structure"])
    except (TypeError, ValueError) as err:
        raise ConfigError(f"config key 'tube.structure': {err}") from None
    for name, spec in tube["branches"].items():
        dofs = 2 * (beam.n_elements + 1)
        if spec["mode"] > dofs:
            raise ConfigError(
                f"config key 'tube.branches.{name}.mode': {spec['mode']} exceeds the {dofs} degrees of "
                "freedom of the mesh"
            )


def load_config(path: str | Path = "config/config.yaml") -> dict:
    """Read a YAML configuration file and validate it."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"configuration file not found: {path}")
    with path.open() as fh:
        config = yaml.safe_load(fh)
    if not isinstance(config, dict):
        raise ConfigError(f"configuration file {path} does not hold a mapping")
    return validate_config(config)
