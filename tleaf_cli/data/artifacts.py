"""Parquet artifacts with provenance, written atomically.

Every artifact carries `tleaf.kind`, `tleaf.schema`, `tleaf.version`, `tleaf.params` (JSON of the
options used) and `tleaf.inputs` (JSON list of {path, sha256}) as Parquet key-value metadata, so a
file says how it was made. A write goes to a temporary file beside the target and is renamed over
it, so a crash never leaves half an artifact.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from tleaf_cli.errors import InputError
from tleaf_cli.version import __version__

PREFIX = "tleaf."


@dataclass(frozen=True)
class Provenance:
    """What an artifact's metadata says about it."""

    kind: str
    schema: int
    version: str
    params: dict[str, Any]
    inputs: list[dict[str, str]]


def read_text_file(path: str | os.PathLike) -> str:
    """A user's text file as text: UTF-8, a byte-order mark at the start dropped (Notepad writes
    one; read as text it would join the first line's first word). InputError naming the file
    when it is missing or unreadable, or not UTF-8 (with the first bad byte)."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except OSError as e:
        raise InputError(f"{path}: cannot read ({e.strerror})") from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:  # e.object is the data after the mark
        byte = e.start + len(data) - len(e.object)
        raise InputError(f"{path}: not UTF-8 text (byte {byte})") from None


def read_json_file(path: str | os.PathLike) -> Any:
    """A user's JSON file (`read_text_file`, then parsed); InputError naming the file and the
    line for text that is not JSON."""
    try:
        return json.loads(read_text_file(path))
    except json.JSONDecodeError as e:
        raise InputError(f"{path}: not JSON (line {e.lineno}: {e.msg})") from None


def file_sha256(path: str | os.PathLike) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def describe_inputs(paths: Iterable[str | os.PathLike]) -> list[dict[str, str]]:
    """Each input as an absolute path (a later stage run from another folder still finds it)
    and the SHA-256 of its bytes."""
    return [{"path": str(Path(p).resolve()), "sha256": file_sha256(p)} for p in paths]


def relative_to(folder: str | os.PathLike, target: str | os.PathLike) -> str:
    """`target` as a path relative to `folder`: how a model folder records a folder it depends
    on, beside the absolute path, so that a whole tree moved or copied keeps loading."""
    return os.path.relpath(Path(target).resolve(), Path(folder).resolve())


def check_writable(target: str | os.PathLike) -> None:
    """InputError now, before any work, if file `target` cannot be written. Nothing is created
    (a refused call writes nothing); the folder is made when the file is written."""
    target = Path(target)
    if target.is_dir():
        raise InputError(f"{target}: is a folder; give a file name")
    check_folder_writable(target.parent)
    if target.parent.is_dir():  # a folder that says it is writable and is not (/proc, /sys)
        try:
            with tempfile.TemporaryFile(dir=target.parent):
                pass
        except OSError as e:
            raise InputError(f"{target}: cannot be written ({e.strerror or e})") from None


def check_folder_writable(target: str | os.PathLike) -> None:
    """InputError now, before any work, if folder `target` cannot be made or written in.

    Nothing is created: the nearest folder that exists must be writable, and no part of the
    path may be an existing file."""
    target = Path(target)
    existing = target
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        what = "is" if existing == target else f"needs folder {existing}, which is"
        raise InputError(f"{target}: {what} an existing file, not a folder")
    if not os.access(existing, os.W_OK):
        raise InputError(f"{target}: folder {existing} is not writable")


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """True when the two paths name one file or folder, however written: `./x` and `x`, a
    symbolic link and its target, two hard links."""
    a, b = Path(a), Path(b)
    if a.resolve() == b.resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet)
        return False


def check_targets(
    inputs: Iterable[str | os.PathLike | None],
    files: Iterable[str | os.PathLike | None] = (),
    folders: Iterable[str | os.PathLike | None] = (),
) -> None:
    """InputError now, before any work, unless every output can be written and none of them is
    an input or another output (writing it would destroy the input, or the first output).

    `files` are output files, `folders` output folders (a model or report directory, with the
    files the stage writes in it listed in `files` where an input could be one of them);
    None entries (options not given) are skipped. Call it before reading anything, so that a
    stage that refuses its call writes nothing.
    """
    sources = [Path(i) for i in inputs if i is not None]
    files = [Path(f) for f in files if f is not None]
    folders = [Path(f) for f in folders if f is not None]
    outputs = [*files, *folders]
    for k, out in enumerate(outputs):
        for source in sources:
            if same_file(out, source):
                given = "" if str(out) == str(source) else f" (given as {source})"
                raise InputError(
                    f"{out}: is also an input{given}; writing it would destroy the input, "
                    "give another output path"
                )
        for other in outputs[:k]:
            if same_file(out, other):
                raise InputError(f"{out}: given for two outputs (also as {other})")
    for folder in folders:
        check_folder_writable(folder)
    for file in files:
        check_writable(file)


def atomic_path(target: str | os.PathLike):
    """A temporary path in the target's directory; rename it over the target when done."""
    target = Path(target)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    except OSError as e:  # named as the user gave it, not by the temporary file
        raise InputError(f"{target}: cannot be written ({e.strerror or e})") from None
    os.close(fd)
    os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; artifacts get the usual mode
    return Path(tmp)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_text_atomic(target: str | os.PathLike, text: str) -> None:
    tmp = atomic_path(target)
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)


def write_artifact(
    table: pa.Table,
    path: str | os.PathLike,
    *,
    kind: str,
    schema: int,
    params: dict[str, Any],
    inputs: list[dict[str, str]],
) -> None:
    """Write `table` to `path` with provenance metadata, atomically."""
    meta = dict(table.schema.metadata or {})
    meta.update(
        {
            f"{PREFIX}kind".encode(): kind.encode(),
            f"{PREFIX}schema".encode(): str(schema).encode(),
            f"{PREFIX}version".encode(): __version__.encode(),
            f"{PREFIX}params".encode(): json.dumps(params, sort_keys=True, default=str).encode(),
            f"{PREFIX}inputs".encode(): json.dumps(inputs).encode(),
        }
    )
    tmp = atomic_path(path)
    try:
        pq.write_table(table.replace_schema_metadata(meta), tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def read_provenance(path: str | os.PathLike) -> Provenance:
    """Provenance of a tleaf artifact; InputError when the file is not one."""
    try:
        meta = pq.read_schema(path).metadata or {}
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (pa.ArrowException, OSError) as e:
        raise InputError(f"{path}: not a Parquet file ({_first_line(e)})") from None
    get = {k.decode(): v.decode() for k, v in meta.items() if k.startswith(PREFIX.encode())}
    if f"{PREFIX}kind" not in get:
        raise InputError(f"{path}: a Parquet file without tleaf metadata (not a tleaf artifact)")
    try:
        return Provenance(
            kind=get[f"{PREFIX}kind"],
            schema=int(get.get(f"{PREFIX}schema", "0")),
            version=get.get(f"{PREFIX}version", "?"),
            params=json.loads(get.get(f"{PREFIX}params", "{}")),
            inputs=json.loads(get.get(f"{PREFIX}inputs", "[]")),
        )
    except ValueError:
        raise InputError(f"{path}: damaged tleaf metadata") from None


def read_artifact(path: str | os.PathLike, kind: str, schema: int) -> tuple[pa.Table, Provenance]:
    """Read an artifact of the expected kind and schema, or InputError saying what it is."""
    prov = read_provenance(path)
    if prov.kind != kind:
        raise InputError(f"{path}: a '{prov.kind}' artifact, expected '{kind}'")
    if prov.schema != schema:
        raise InputError(
            f"{path}: {kind} schema {prov.schema}, this tleaf reads schema {schema}; "
            "re-create it with this version"
        )
    try:
        return pq.read_table(path), prov
    except (pa.ArrowException, OSError) as e:
        raise InputError(f"{path}: unreadable ({_first_line(e)})") from None


def _first_line(e: BaseException) -> str:
    return (str(e).strip().splitlines() or [e.__class__.__name__])[0]
