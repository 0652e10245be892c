"""A result bundle to share and cite: one deterministic zip archive with an RO-Crate.

:func:`build_bundle` packs the datasets and figures of a run with what is needed to
trust and reuse them (SHA-256 manifest, the configuration used, ``environment.lock``,
the workflow, the repository's ``CITATION.cff``) and describes them in ``ro-crate-metadata.json``
(RO-Crate 1.1, Workflow Run Crate profile) written with the ``rocrate`` library.
:func:`verify_bundle` opens an archive with ``rocrate`` and checks every listed file
against its recorded size and SHA-256.

The archive is byte-reproducible: entries sorted, fixed timestamps and permissions, and
no wall-clock date anywhere (``datePublished`` is the commit date that
:func:`nnmstop.netcdf.provenance` gives the datasets).
"""

from __future__ import annotations

import hashlib
import tempfile
import zipfile
from pathlib import Path

import yaml

from nnmstop import __version__
from nnmstop.atomic import atomic_output
from nnmstop.netcdf import provenance

__all__ = ["ENCODING_FORMATS", "build_bundle", "verify_bundle"]

# Media types of the bundled files, by suffix (IANA where one exists).
ENCODING_FORMATS = {
    ".nc": "application/x-netcdf",
    ".pdf": "application/pdf",
    ".png": "image/png",
    ".html": "text/html",  # dist/explorer.html
    ".sha256": "text/plain",
    ".lock": "text/plain",
    ".yaml": "application/yaml",
    ".cff": "application/yaml",
    ".smk": "text/x-python",
    "": "text/x-python",  # Snakefile
}
_PROFILES = {
    "https://w3id.org/ro/wfrun/process/0.5": "Process Run Crate",
    "https://w3id.org/ro/wfrun/workflow/0.5": "Workflow Run Crate",
    "https://w3id.org/workflowhub/workflow-ro-crate/1.0": "Workflow RO-Crate",
}
# Zip entries get this timestamp (the earliest a zip can hold) and these permissions.
_ZIP_DATE = (1980, 1, 1, 0, 0, 0)
_ZIP_MODE = 0o644 << 16


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _file_properties(path: Path, name: str) -> dict:
    suffix = path.suffix if path.name != "Snakefile" else ""
    if suffix not in ENCODING_FORMATS:
        raise ValueError(f"no encoding format known for {path.name!r}; known suffixes: {sorted(ENCODING_FORMATS)}")
    return {
        "name": name,
        "encodingFormat": ENCODING_FORMATS[suffix],
        "contentSize": str(path.stat().st_size),
        "sha256": _sha256(path),
    }


def _bundle_metadata(config: dict) -> dict:
    if "metadata" not in config:
        raise ValueError("the configuration has no 'metadata' section; the bundle's creator and license come from it")
    return config["metadata"]


def _check_inputs(root: Path, relative: list, citation_file: Path) -> None:
    """Every listed file exists under ``root``, once, by a relative path; ``citation_file`` exists."""
    for path in relative:
        if path.is_absolute():
            raise ValueError(f"{path} must be relative to root {root}: it keeps that path in the archive")
        if not (root / path).is_file():
            raise ValueError(f"bundle input {path} does not exist under {root}")
    if len(set(relative)) != len(relative):
        raise ValueError("a dataset or figure is listed twice")
    if not citation_file.is_file():
        raise ValueError(f"bundle input {citation_file} (CITATION.cff) does not exist")


def _agent(crate, metadata: dict, role: str):
    """The creator or publisher (``role``) of the configuration's metadata as a context entity of ``crate``."""
    from rocrate.model.contextentity import ContextEntity

    return crate.add(
        ContextEntity(
            crate,
            metadata[f"{role}_url"],
            properties={
                "@type": "Organization" if metadata[f"{role}_type"] != "person" else "Person",
                "name": metadata[f"{role}_name"],
                "email": metadata[f"{role}_email"],
            },
        )
    )


def _described_crate(metadata: dict):
    """An empty RO-Crate with the bundle's name, description, license, date, version, profiles and agents."""
    from rocrate.model.contextentity import ContextEntity
    from rocrate.rocrate import ROCrate

    crate = ROCrate(version="1.1")
    crate.name = f"{metadata['project']}: result bundle"
    crate.description = (
        "Datasets (NetCDF, CF-1.10 / ACDD-1.3) and figures of one run of the nnmstop pipeline, with the "
        "configuration, the locked environment and the Snakemake workflow that produced them."
    )
    crate.license = metadata["license"]
    crate.root_dataset["datePublished"] = provenance()["date_created"]
    crate.root_dataset["version"] = __version__
    crate.root_dataset["conformsTo"] = [
        crate.add(
            ContextEntity(
                crate, url, properties={"@type": "CreativeWork", "name": name, "version": url.rsplit("/", 1)[1]}
            )
        )
        for url, name in _PROFILES.items()
    ]
    crate.creator = _agent(crate, metadata, "creator")
    crate.publisher = _agent(crate, metadata, "publisher")
    return crate


def _write_archive(staged: Path, output: Path) -> None:
    """Zip the written crate ``staged`` into ``output`` with fixed dates and modes (byte-reproducible)."""
    members = sorted(p for p in staged.rglob("*") if p.is_file())
    with (
        atomic_output(output) as partial,
        zipfile.ZipFile(partial, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=6) as archive,
    ):
        for member in members:
            info = zipfile.ZipInfo(member.relative_to(staged).as_posix(), date_time=_ZIP_DATE)
            info.external_attr = _ZIP_MODE
            info.compress_type = zipfile.ZIP_DEFLATED
            archive.writestr(info, member.read_bytes(), compresslevel=6)


def _add_workflow(crate, workflow_files: list):
    """The main Snakefile (the crate's ``ComputationalWorkflow``, returned) and its rule files."""
    main_workflow, *rule_files = workflow_files
    workflow = crate.add_workflow(
        main_workflow,
        "Snakefile",
        main=True,
        lang="snakemake",
        properties=_file_properties(main_workflow, "Snakemake workflow of the nnmstop pipeline"),
    )
    for rule_file in sorted(rule_files):
        crate.add_file(
            rule_file,
            f"workflow/rules/{rule_file.name}",
            properties=_file_properties(rule_file, f"Snakemake rules {rule_file.name}"),
        )
    return workflow


def build_bundle(
    config: dict,
    datasets: list,
    figures: list,
    manifest,
    environment_lock,
    workflow_files: list,
    output,
    root=".",
    citation_file="CITATION.cff",
) -> Path:
    """Write the result bundle ``output`` (a zip archive) and return its path.

    Parameters
    ----------
    config
        The validated configuration of the run; written as ``config/config.yaml`` and used
        for the crate's metadata (section ``metadata``).
    datasets, figures
        Paths of the run's datasets (``*.nc``) and figures, relative to ``root``; each keeps
        that relative path in the archive and is a ``result`` of the run's ``CreateAction``.
    manifest
        ``results/MANIFEST.sha256`` (relative to ``root``).
    environment_lock
        The ``environment.lock`` the run was made with (stored as ``environment.lock``).
    workflow_files
        The main ``Snakefile`` first (the crate's ``ComputationalWorkflow``), then the rule
        files it includes (stored under ``workflow/rules/``).
    output
        The archive to write, e.g. ``dist/nnmstop-results.zip``.
    root
        Folder the relative paths of ``datasets``, ``figures`` and ``manifest`` start from.
    citation_file
        The repository's ``CITATION.cff``, stored unchanged as ``CITATION.cff`` (how to cite
        the software and the paper).

    Raises
    ------
    ValueError
        If ``config`` has no ``metadata`` section, a listed file is missing, or a path
        appears twice.
    """
    metadata = _bundle_metadata(config)
    root = Path(root)
    citation_file = Path(citation_file)
    _check_inputs(root, [Path(p) for p in (*datasets, *figures, manifest)], citation_file)
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)

    with tempfile.TemporaryDirectory(prefix="nnmstop-bundle-") as tmp:
        generated = Path(tmp) / "generated"
        generated.mkdir()
        config_copy = generated / "config.yaml"
        config_copy.write_text(yaml.safe_dump(config, sort_keys=False, allow_unicode=True))
        crate = _described_crate(metadata)
        workflow = _add_workflow(crate, [Path(p) for p in workflow_files])
        configuration = crate.add_file(
            config_copy,
            "config/config.yaml",
            properties=_file_properties(config_copy, "configuration of the run (validated)"),
        )
        results = [
            crate.add_file(root / path, path.as_posix(), properties=_file_properties(root / path, path.name))
            for path in sorted(Path(p) for p in (*datasets, *figures))
        ]
        for source, name, what in (
            (root / manifest, Path(manifest).as_posix(), "SHA-256 manifest of the datasets"),
            (Path(environment_lock), "environment.lock", "locked Python environment (pip-compile)"),
            (citation_file, "CITATION.cff", "how to cite the software"),
        ):
            crate.add_file(source, name, properties=_file_properties(source, what))
        crate.add_action(
            workflow,
            identifier="#run",
            object=[configuration],
            result=results,
            properties={
                "name": f"Run of the nnmstop workflow (nnmstop {__version__}, git commit {provenance()['commit']})",
                "actionStatus": "http://schema.org/CompletedActionStatus",
            },
        )
        staged = Path(tmp) / "crate"
        crate.write(staged)
        _write_archive(staged, output)
    return output


def verify_bundle(path) -> list[str]:
    """Open the bundle ``path`` with ``rocrate`` and check every listed file.

    Returns
    -------
    list of str
        One line per problem (a listed file missing from the archive, or whose size or
        SHA-256 differs from the crate's record); empty when the bundle is intact.
    """
    from rocrate.rocrate import ROCrate

    problems = []
    with tempfile.TemporaryDirectory(prefix="nnmstop-verify-") as tmp:
        with zipfile.ZipFile(path) as archive:
            archive.extractall(tmp)
        crate = ROCrate(tmp)
        for entity in crate.data_entities:
            if "File" not in entity.type:
                continue
            target = Path(tmp) / entity.id
            if not target.is_file():
                problems.append(f"{entity.id}: listed in the crate but missing from the archive")
                continue
            if str(target.stat().st_size) != str(entity.get("contentSize")):
                problems.append(
                    f"{entity.id}: {target.stat().st_size} bytes, the crate records {entity.get('contentSize')}"
                )
            if _sha256(target) != entity.get("sha256"):
                problems.append(f"{entity.id}: SHA-256 differs from the crate's record")
    return problems
