"""Loading and validating the pipeline configuration (``config/config.yaml``).

The JSON Schema lives beside this module (``config_schema.yaml``). Every error
names the offending key, for example ``config key 'model.alpha': -1.0 is less than
or equal to the minimum of 0``.
"""

from __future__ import annotations

import math
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


def _non_finite(node, path: str = ""):
    """(key, value) of the first NaN or infinite number in ``node`` (nested mappings and lists), or None.

    JSON Schema's bounds let NaN through (every comparison with NaN is false) and YAML writes
    ``.nan`` and ``.inf``; no key of the configuration means a non-finite number."""
    if isinstance(node, float) and not math.isfinite(node):
        return path or "<root>", node
    if isinstance(node, dict):
        items = ((f"{path}.{key}" if path else str(key), value) for key, value in node.items())
    elif isinstance(node, list):
        items = ((f"{path}[{index}]", value) for index, value in enumerate(node))
    else:
        return None
    for key, value in items:
        found = _non_finite(value, key)
        if found:
            return found
    return None


def validate_config(config: dict) -> dict:
    """Check ``config`` against the schema and the cross-key rules; return it unchanged.

    Raises
    ------
    ConfigError
        Naming the first offending key and what is allowed there.
    """
    if not isinstance(config, dict):
        raise ConfigError(f"the configuration must be a mapping of sections, got {type(config).__name__}")
    found = _non_finite(config)
    if found:
        raise ConfigError(f"config key '{found[0]}': {found[1]} is not a finite number; every number must be finite")
    validator = jsonschema.Draft202012Validator(load_schema())
    errors = sorted(validator.iter_errors(config), key=lambda e: (len(e.absolute_path), str(e.absolute_path)))
    if errors:
        first = errors[0]
        raise ConfigError(f"config key '{_key_path(first)}': {first.message}")
    model = config.get("model", {"alpha": 1.0, "eta": 0.0})
    if model["eta"] >= model["alpha"]:
        raise ConfigError(
            f"config key 'model.eta': {model['eta']} must be smaller than model.alpha = {model['alpha']} "
            "(the regularized force has no admissible branch otherwise)"
        )
    for name, spec in config.get("bifurcations", {}).items():
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
    if "structure" in config:
        _check_structure(config["structure"], config["branches"], "structure")
    if "tube" in config:
        _check_structure({"kind": "beam", "beam": config["tube"]["structure"]}, config["tube"]["branches"], "tube")
    if "tube_plates" in config:
        plates = config["tube_plates"]
        section = {"kind": "beam", "beam": plates["structure"], "reduction": plates["reduction"]}
        _check_structure(section, plates["branches"], "tube_plates")
    if "forced" in config:
        _check_forced(config)
    if "atlas" in config:
        _check_atlas(config)
    return config


def _check_atlas(config: dict) -> None:
    """Every atlas map builds: its structure, damping and force DOFs, slices covering its seeds and checks
    (nnmstop.bifurcation_atlas.maps)."""
    from nnmstop.bifurcation_atlas.maps import atlas_maps

    try:
        atlas_maps(config)
    except (TypeError, ValueError) as err:
        raise ConfigError(f"config key 'atlas': {err}") from None


def _check_forced(config: dict) -> None:
    """The scenes build, are distinct and can be computed (:func:`nnmstop.forced.scenes.check_forced_section`)."""
    from nnmstop.forced.scenes import check_forced_section

    try:
        check_forced_section(config)
    except (TypeError, ValueError) as err:
        raise ConfigError(f"config key 'forced': {err}") from None


def _check_structure(section: dict, branches: dict, key: str) -> None:
    """The structure must build (stops on the model, symmetric matrices, ...), be held, and have the branches' modes."""
    import copy

    from nnmstop.models.structure import check_grounded

    kind = section["kind"]
    where = f"{key}.structure" if key in ("tube", "tube_plates") else f"structure.{kind}"
    try:
        if kind == "two_dof":
            return
        if kind == "beam":
            from nnmstop.models.beam import Beam, beam_structure

            beam = Beam.from_parameters(copy.deepcopy(section["beam"]))
            _check_no_rigid_body_mode(beam)
            structure = beam_structure(beam)
        else:
            from nnmstop.models.matrices import matrix_structure

            spec = section["matrices"]
            structure = matrix_structure(spec["mass"], spec["stiffness"], spec["stops"], spec.get("dof_labels"))
        check_grounded(structure, kind)
    except (TypeError, ValueError) as err:
        raise ConfigError(f"config key '{where}': {err}") from None
    if "reduction" in section:
        from nnmstop.models.reduction import reduce_structure

        reduction_key = f"{key}.reduction" if key in ("tube", "tube_plates") else "structure.reduction"
        try:
            structure = reduce_structure(structure, section["reduction"], reduction_key)
        except (TypeError, ValueError) as err:
            raise ConfigError(f"config key '{reduction_key}': {err}") from None
    for name, spec in branches.items():
        if spec["mode"] > structure.n_dofs:
            branch_key = f"{key}.branches.{name}.mode" if key in ("tube", "tube_plates") else f"branches.{name}.mode"
            raise ConfigError(
                f"config key '{branch_key}': {spec['mode']} exceeds the {structure.n_dofs} degrees of freedom "
                f"of the {kind}"
            )


def _check_no_rigid_body_mode(beam) -> None:
    """A beam's ends must hold it without its stops: in free flight the non-smooth model has no zero-frequency mode."""
    from nnmstop.models.beam import rigid_body_modes

    rigid = rigid_body_modes(beam.left, beam.right)
    if rigid:
        raise ValueError(
            f"a beam {beam.left} at the left end and {beam.right} at the right end has {rigid} rigid-body mode(s) "
            "(zero stiffness, a singular model): its NNMs do not start from a linear mode. Clamp or pin an end so "
            "that no rigid-body motion is left (left/right: clamped or pinned)"
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
