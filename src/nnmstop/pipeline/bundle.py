"""A result bundle to share and cite: one deterministic zip archive with an RO-Crate.

:func:`build_bundle` packs the datasets and figures of a run with what is needed to
trust and reuse them (SHA-256 manifest, the configuration used, ``environment.lock``,
the workflow, the repository's ``CITATION.cff``) and describes them in ``ro-crate-metadata.json``
(RO-Crate 1.1, Workflow Run Crate profile) written with the ``rocrate`` library.
:func:`verify_bundle` checks that an archive is exactly what its crate lists: no member
outside the archive's folder or missing from the crate, every listed file inside the archive with
its recorded size and SHA-256, and every dataset with the SHA-256 of the bundled manifests
(``python -m nnmstop.pipeline.bundle BUNDLE`` on the command line).

The archive is byte-reproducible: entries sorted, fixed timestamps and permissions, and
no wall-clock date anywhere (``datePublished`` is the commit date that
:func:`nnmstop.netcdf.provenance` gives the datasets).
"""

from __future__ import annotations

import hashlib
import stat
import sys
import tempfile
import zipfile
from pathlib import Path

import yaml

from nnmstop import __version__
from nnmstop.atomic import atomic_output
from nnmstop.netcdf import provenance

__all__ = ["ENCODING_FORMATS", "build_bundle", "verify_bundle", "main"]

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


def _check_listed(root: Path, datasets: list, manifests: list) -> None:
    """Every dataset is listed in one of the build's ``manifests`` with its SHA-256 (the bundle ships what the
    build checked), and every dataset a manifest lists is bundled."""
    listed = {}
    for manifest in manifests:
        for line in (root / manifest).read_text().splitlines():
            digest, sep, member = line.partition("  ")
            if sep:
                listed[member] = digest
    for dataset in map(Path, datasets):
        digest = listed.get(dataset.as_posix())
        if digest is None:
            raise ValueError(f"bundle input {dataset} is listed in no manifest of {[str(m) for m in manifests]}")
        if _sha256(root / dataset) != digest:
            raise ValueError(f"bundle input {dataset} differs from its manifest's SHA-256: rebuild the manifest")
    missing = sorted(set(listed) - {Path(d).as_posix() for d in datasets})
    if missing:
        raise ValueError(f"the manifests list datasets that are not bundled: {missing}")


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
        ``results/MANIFEST.sha256`` (relative to ``root``), or a list of the build's manifests (with the
        forced responses' ``results/forced/MANIFEST.sha256``): together they must list every dataset.
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
        If ``config`` has no ``metadata`` section, a listed file is missing, a path appears twice, or a
        dataset is not in the manifests with its SHA-256.
    """
    metadata = _bundle_metadata(config)
    root = Path(root)
    citation_file = Path(citation_file)
    manifests = [manifest] if isinstance(manifest, (str, Path)) else list(manifest)
    _check_inputs(root, [Path(p) for p in (*datasets, *figures, *manifests)], citation_file)
    _check_listed(root, datasets, manifests)
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
            *((root / m, Path(m).as_posix(), "SHA-256 manifest of the datasets") for m in manifests),
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


#: The crate's own description: the one archive member that is no data entity.
CRATE_METADATA = "ro-crate-metadata.json"


def _unsafe_name(name: str) -> str:
    """Why an archive member's name would land outside the folder it is extracted to ("" if it would not)."""
    if name.startswith(("/", "\\")) or (len(name) > 1 and name[1] == ":"):
        return "an absolute name"
    if ".." in name.replace("\\", "/").split("/"):
        return "a name with '..'"
    return ""


def _inside(root: Path, entity_id: str) -> Path | None:
    """The file of a crate entity ``@id`` in the extracted archive ``root``; None if it resolves outside it (an
    absolute path, ``..``, a link, a URL)."""
    if "://" in entity_id or _unsafe_name(entity_id):
        return None
    target = (root / entity_id).resolve()
    return target if target.is_relative_to(root.resolve()) else None


def _manifest_lines(text: str, name: str, problems: list) -> dict:
    """``{path: sha256}`` of a bundled ``sha256sum`` manifest; a malformed line is a problem."""
    listed = {}
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        digest, sep, member = line.partition("  ")
        if not sep or len(digest) != 64:
            problems.append(f"{name}: line {number} is not '<sha256>  <path>': {line[:80]!r}")
            continue
        listed[member] = digest
    return listed


def verify_bundle(path, quiet: bool = False) -> list[str]:
    """Check that the bundle ``path`` is exactly what its crate lists; print what was checked (unless ``quiet``).

    * every archive member has a safe name (none absolute or with ``..``; such members are not extracted)
      and is listed in the crate (``ro-crate-metadata.json``), the crate's own file aside;
    * every file the crate lists lies inside the archive (an ``@id`` that resolves outside it is refused and
      never opened), is present, and has the size and SHA-256 the crate records;
    * the bundled dataset manifests (``*MANIFEST.sha256``) list every dataset of the bundle with its
      SHA-256, and every dataset they list is a file of the crate.

    Returns
    -------
    list of str
        One line per problem, naming the member or entity; empty when the bundle is intact.
    """
    from rocrate.rocrate import ROCrate

    problems: list[str] = []
    with tempfile.TemporaryDirectory(prefix="nnmstop-verify-") as tmp:
        root = Path(tmp)
        try:
            archive = zipfile.ZipFile(path)
        except (OSError, zipfile.BadZipFile) as error:
            return [f"{path}: not a zip archive ({error})"]
        with archive:
            members = []
            for info in archive.infolist():
                if info.is_dir():
                    continue
                why = _unsafe_name(info.filename)
                if why:
                    problems.append(f"{info.filename}: {why}, outside the archive's folder (not extracted)")
                    continue
                if stat.S_ISLNK(info.external_attr >> 16):
                    problems.append(f"{info.filename}: a symbolic link (not extracted)")
                    continue
                members.append(info.filename)
                archive.extract(info, root)
        if CRATE_METADATA not in members:
            problems.append(f"{CRATE_METADATA}: missing; the archive is not an RO-Crate")
            return _reported(problems, quiet, path, members, 0, 0)
        try:
            crate = ROCrate(root)
        except Exception as error:  # rocrate raises what its JSON-LD parsing meets
            problems.append(f"{CRATE_METADATA}: cannot be read as an RO-Crate ({type(error).__name__}: {error})")
            return _reported(problems, quiet, path, members, 0, 0)
        files = {}
        for entity in crate.data_entities:
            if "File" not in entity.type:
                continue
            target = _inside(root, entity.id)
            if target is None:
                problems.append(f"{entity.id}: the crate lists a file outside the archive (not opened)")
                continue
            files[Path(entity.id).as_posix()] = entity
            if not target.is_file():
                problems.append(f"{entity.id}: listed in the crate but missing from the archive")
                continue
            if str(target.stat().st_size) != str(entity.get("contentSize")):
                problems.append(
                    f"{entity.id}: {target.stat().st_size} bytes, the crate records {entity.get('contentSize')}"
                )
            if _sha256(target) != entity.get("sha256"):
                problems.append(f"{entity.id}: SHA-256 differs from the crate's record")
        for member in sorted(set(members) - set(files) - {CRATE_METADATA}):
            problems.append(f"{member}: in the archive but not listed in the crate")
        manifests = sorted(m for m in files if m.endswith("MANIFEST.sha256") and (root / m).is_file())
        listed, source = {}, {}
        for manifest in manifests:
            lines = _manifest_lines((root / manifest).read_text(), manifest, problems)
            listed.update(lines)
            source.update(dict.fromkeys(lines, manifest))
        if not manifests:
            problems.append("results/MANIFEST.sha256: the bundle holds no dataset manifest")
        for member, digest in sorted(listed.items()):
            if member not in files:
                problems.append(f"{member}: listed in {source[member]} but not a file of the crate")
            elif (root / member).is_file() and _sha256(root / member) != digest:
                problems.append(f"{member}: SHA-256 differs from the bundled manifest's")
        for member in sorted(m for m in files if m.endswith(".nc") and m not in listed):
            problems.append(f"{member}: a dataset of the bundle that no bundled manifest lists")
        return _reported(problems, quiet, path, members, len(files), len(listed))


def _reported(problems: list, quiet: bool, path, members: list, files: int, datasets: int) -> list:
    """``problems``, after printing what was checked to the standard output (unless ``quiet``)."""
    if not quiet:
        print(
            f"{path}: {len(members)} archive members (safe names, each listed in the crate), {files} files of the "
            f"crate (inside the archive, size and SHA-256), {datasets} datasets of the bundled manifests "
            f"(SHA-256, each a file of the crate): {len(problems)} problem(s)"
        )
    return problems


def main(argv=None) -> int:
    """Command line: ``python -m nnmstop.pipeline.bundle BUNDLE`` checks a bundle (exit 1 on a problem)."""
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m nnmstop.pipeline.bundle", description=verify_bundle.__doc__.split("\n")[0]
    )
    parser.add_argument("bundle", help="the zip archive, e.g. dist/nnmstop-results.zip")
    problems = verify_bundle(parser.parse_args(argv).bundle)
    for problem in problems:
        print(problem)
    print("intact" if not problems else f"{len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
