"""Downloads of the public Middlebury scenes: the registry and the fetcher (extra ``data``).

:func:`fetch` downloads a scene of :data:`REGISTRY` into the cache (:func:`default_cache_dir`)
with pooch, checks what it can, and unpacks it into a folder that
:func:`dcstereo.evaluation.datasets.load_scene` reads.
"""

import hashlib
import json
import os
import shutil
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

from dcstereo._extras import require

# --- registry and fetcher -------------------------------------------------------------

#: Environment variable that overrides the download cache of :func:`fetch`.
CACHE_ENV_VAR = "DCSTEREO_CACHE"

_MIDDLEBURY = "https://vision.middlebury.edu/stereo/data"
_CITE_2005 = (
    "D. Scharstein and C. Pal. Learning conditional random fields for stereo. CVPR 2007; "
    "H. Hirschmueller and D. Scharstein. Evaluation of cost functions for stereo matching. "
    "CVPR 2007."
)
_CITE_2014 = (
    "D. Scharstein, H. Hirschmueller, Y. Kitajima, G. Krathwohl, N. Nesic, X. Wang and "
    "P. Westling. High-resolution stereo datasets with subpixel-accurate ground truth. "
    "GCPR 2014."
)


@dataclass(frozen=True)
class RemoteFile:
    """One file of a registry entry.

    Attributes
    ----------
    url : str
        Where to download it.
    sha256 : str or None
        Its SHA-256 checksum (64 hex digits); None when it has not been verified by the
        project, in which case :func:`fetch` refuses it unless told to accept it.
    """

    url: str
    sha256: str | None = None


@dataclass(frozen=True)
class RegistryEntry:
    """A downloadable scene (or set of scenes).

    Attributes
    ----------
    name : str
        Registry key.
    layout : str
        A key of :data:`LAYOUTS`.
    files : tuple of RemoteFile
        Zip archives are extracted, other files are stored as they are.
    folder : str
        The scene folder (or the folder of scenes) inside the entry's cache folder once
        the files are in place; ``""`` for the entry's folder itself.
    description : str
    citation : str
    """

    name: str
    layout: str
    files: tuple[RemoteFile, ...]
    folder: str
    description: str
    citation: str

    @property
    def verified(self) -> bool:
        """Whether every file has a checksum."""
        return all(f.sha256 is not None for f in self.files)


def _registry() -> dict[str, RegistryEntry]:
    # The checksums are None: this project could not download the files to hash them.
    # `dcstereo datasets fetch NAME --allow-unverified` prints the hashes it computes;
    # confirm them with a trusted source before writing them here.
    entries = {}
    for year, scenes in (
        ("2005", ("Art", "Books", "Dolls", "Laundry", "Moebius", "Reindeer")),
        (
            "2006",
            "Aloe Baby1 Baby2 Baby3 Bowling1 Bowling2 Cloth1 Cloth2 Cloth3 Cloth4 Flowerpots "
            "Lampshade1 Lampshade2 Midd1 Midd2 Monopoly Plastic Rocks1 Rocks2 Wood1 "
            "Wood2".split(),
        ),
    ):
        for scene in scenes:
            name = f"{scene.lower()}-{year}-third"
            url = f"{_MIDDLEBURY}/scenes{year}/ThirdSize/zip-2views/{scene}-2views.zip"
            entries[name] = RegistryEntry(
                name=name,
                layout="2005/2006",
                files=(RemoteFile(url),),
                folder=scene,
                description=f"Middlebury {year} {scene}, third size, views 1 and 5",
                citation=_CITE_2005,
            )
    for scene in (
        "Adirondack Backpack Bicycle1 Cable Classroom1 Couch Flowers Jadeplant Mask "
        "Motorcycle Piano Pipes Playroom Playtable Recycle Shelves Shopvac Sticks Storage "
        "Sword1 Sword2 Umbrella Vintage".split()
    ):
        name = f"{scene.lower()}-2014"
        base = f"{_MIDDLEBURY}/scenes2014/datasets/{scene}-perfect"
        entries[name] = RegistryEntry(
            name=name,
            layout="2014",
            files=tuple(
                RemoteFile(f"{base}/{file}")
                for file in ("im0.png", "im1.png", "disp0.pfm", "disp1.pfm", "calib.txt")
            ),
            folder="",
            description=f"Middlebury 2014 {scene} (perfect rectification), full size",
            citation=_CITE_2014,
        )
    entries["middeval3-training-q"] = RegistryEntry(
        name="middeval3-training-q",
        layout="2014",
        files=(
            RemoteFile("https://vision.middlebury.edu/stereo/submit3/zip/MiddEval3-data-Q.zip"),
            RemoteFile("https://vision.middlebury.edu/stereo/submit3/zip/MiddEval3-GT0-Q.zip"),
        ),
        folder="MiddEval3/trainingQ",
        description="Middlebury v3 (MiddEval3) training set, quarter size, 15 scenes",
        citation=_CITE_2014,
    )
    return entries


#: Public Middlebury scenes :func:`fetch` can download, by name. Every checksum is
#: currently None (unverified): see :class:`RemoteFile`.
REGISTRY: dict[str, RegistryEntry] = _registry()


def default_cache_dir() -> Path:
    """Download cache of :func:`fetch`: ``$DCSTEREO_CACHE``, else pooch's user cache.

    Returns
    -------
    Path
    """
    override = os.environ.get(CACHE_ENV_VAR)
    if override:
        return Path(override).expanduser()
    pooch = require("pooch", "data", "downloads of the scenes")

    return Path(pooch.os_cache("dcstereo"))


def _extract_zip(archive: Path, target: Path) -> None:
    """Extract into ``target``, refusing members that would land outside it."""
    target = target.resolve()
    with zipfile.ZipFile(archive) as bundle:
        for member in bundle.namelist():
            destination = (target / member).resolve()
            if destination != target and target not in destination.parents:
                raise ValueError(f"{archive} holds a file outside its folder: {member!r}")
        bundle.extractall(target)


def fetch(
    name: str,
    *,
    cache: str | os.PathLike | None = None,
    allow_unverified: bool = False,
    registry: dict[str, RegistryEntry] | None = None,
) -> tuple[Path, dict[str, str]]:
    """Download a registry entry into the cache (once) and return its scene folder.

    Each file is downloaded with pooch and checked against its SHA-256 checksum; a
    mismatch deletes the download and raises. Zip archives are then extracted into
    ``<cache>/<name>/``, other files copied there.

    Parameters
    ----------
    name : str
        A key of the registry.
    cache : path-like, optional
        Cache folder; :func:`default_cache_dir` by default.
    allow_unverified : bool
        Download files whose checksum the registry does not know (they are not checked;
        the returned hashes let you confirm them).
    registry : dict, optional
        The registry to use; :data:`REGISTRY` by default.

    Returns
    -------
    folder : Path
        The scene folder (or folder of scenes) of the entry.
    hashes : dict of str to str
        SHA-256 of every file, by URL.

    Raises
    ------
    ValueError
        Unknown name, an unverified entry without ``allow_unverified``, a checksum
        mismatch (one line; nothing is left in the cache), or a bad archive.
    OSError
        When a download fails.
    """
    pooch = require("pooch", "data", "downloads of the scenes")

    registry = REGISTRY if registry is None else registry
    if name not in registry:
        raise ValueError(
            f"unknown dataset {name!r}; see `dcstereo datasets list` ({len(registry)} entries)"
        )
    entry = registry[name]
    if not entry.verified and not allow_unverified:
        raise ValueError(
            f"the checksum of {name} is not verified in the registry; fetch it with "
            "--allow-unverified (allow_unverified=True) and compare the printed sha256 with a "
            "trusted source"
        )
    cache = Path(cache).expanduser() if cache is not None else default_cache_dir()
    target = cache / name
    done = target / ".complete.json"
    if done.is_file():
        return target / entry.folder, json.loads(done.read_text(encoding="utf-8"))
    downloads = cache / "downloads"
    downloads.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{name}-", dir=cache))
    hashes = {}
    logger = pooch.get_logger()
    level = logger.level
    logger.setLevel("WARNING")  # the hashes are returned; pooch's notes would repeat them
    try:
        for remote in entry.files:
            file_name = f"{name}-{remote.url.rstrip('/').rsplit('/', 1)[-1]}"
            known = f"sha256:{remote.sha256}" if remote.sha256 else None
            try:
                path = Path(
                    pooch.retrieve(
                        remote.url, known, fname=file_name, path=downloads, progressbar=False
                    )
                )
            except ValueError as err:
                text = str(err)
                if "does not match the known hash" in text:
                    got = text.split(" but got ", 1)[-1].split(".", 1)[0].split()[0]
                    raise ValueError(
                        f"checksum mismatch for {name}: {remote.url} has sha256 {got}, the "
                        f"registry expects {remote.sha256}; the download was deleted"
                    ) from None
                raise
            except Exception as err:  # requests' and pooch's own errors, made one kind
                raise OSError(f"cannot download {remote.url}: {err}") from None
            digest = hashlib.sha256(path.read_bytes()).hexdigest()
            hashes[remote.url] = digest
            if zipfile.is_zipfile(path):
                _extract_zip(path, staging)
            else:
                shutil.copyfile(path, staging / path.name[len(name) + 1 :])
        (staging / ".complete.json").write_text(json.dumps(hashes, indent=1), encoding="utf-8")
        if target.exists():
            shutil.rmtree(target)
        staging.rename(target)
    finally:
        logger.setLevel(level)
        if staging.exists():
            shutil.rmtree(staging)
    return target / entry.folder, hashes
