"""The public NEXRAD Level-II archive: find the volume nearest a time, and cache it locally.

The archive moved in September 2025 from the retired ``noaa-nexrad-level2`` bucket to
``s3://unidata-nexrad-level2/`` (anonymous access). Its key layout is one object per volume::

    YYYY/MM/DD/SITE/SITEYYYYMMDD_HHMMSS_V06

(older volumes end ``_V03``, ``_V04`` ... and may carry ``.gz``; ``_MDM`` objects are
metadata, not volumes). The day's folder is listed through fsspec, the volume nearest the
asked time taken (the day before or after too, near midnight), and copied into a local cache
(written beside and renamed, so a cut-off download never looks cached). ``PASIM_NEXRAD_ARCHIVE``
points the same code at another root with the same layout (a mirror, or a local folder in the
tests).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import Any

ARCHIVE = "s3://unidata-nexrad-level2"
#: A volume farther than this from the asked time is not "the volume at that time".
MAX_OFFSET = timedelta(minutes=30)
_NAME = re.compile(r"^(?P<site>[A-Z0-9]{4})(?P<ymd>\d{8})_(?P<hms>\d{6})(?:_V\d{2})?(?:\.gz)?$")


class ArchiveError(RuntimeError):
    """The archive cannot be reached, or holds no volume for that radar and time."""


@dataclass(frozen=True)
class Volume:
    key: str  # the object's key under the archive's root
    time: datetime


def archive_root() -> str:
    return os.environ.get("PASIM_NEXRAD_ARCHIVE", ARCHIVE).rstrip("/")


def parse_time(text: str) -> datetime:
    """``2013-05-20T20:08Z``, ``2013-05-20 20:08:00``, ``20130520T2008`` (UTC)."""
    cleaned = text.strip().removesuffix("Z").removesuffix("z").replace(" ", "T")
    for fmt in ("%Y-%m-%dT%H:%M:%S", "%Y-%m-%dT%H:%M", "%Y%m%dT%H%M%S", "%Y%m%dT%H%M", "%Y-%m-%d"):
        try:
            return datetime.strptime(cleaned, fmt).replace(tzinfo=timezone.utc)
        except ValueError:
            continue
    raise ValueError(f"expected a UTC time like 2013-05-20T20:08Z, found {text!r}")


def _filesystem(root: str) -> tuple[Any, str]:
    import fsspec

    if root.startswith("s3://"):
        try:
            import s3fs  # noqa: F401  (fsspec's s3 protocol)
        except ImportError:
            raise ArchiveError(
                f"reading {root} needs the s3fs package: pip install 'pasim-graph[fetch]'"
            ) from None
        fs = fsspec.filesystem("s3", anon=True)
        return fs, root.removeprefix("s3://")
    try:
        fs, path = fsspec.core.url_to_fs(root)
    except Exception as exc:  # an unknown protocol, or one that connects when made (ftp)
        raise ArchiveError(
            f"cannot open the archive {root}: {type(exc).__name__}: {exc} "
            "(no network, or the archive is unreachable)"
        ) from None
    return fs, path


def volumes_near(site: str, when: datetime) -> list[Volume]:
    """The volumes of ``site`` on the day of ``when`` and the days either side."""
    fs, base = _filesystem(archive_root())
    out = []
    for day in (when - timedelta(days=1), when, when + timedelta(days=1)):
        prefix = f"{base}/{day:%Y/%m/%d}/{site}"
        try:
            names = fs.ls(prefix, detail=False)
        except FileNotFoundError:
            continue
        except Exception as exc:  # no network, refused, throttled: said, not a traceback
            raise ArchiveError(
                f"cannot list {archive_root()}/{day:%Y/%m/%d}/{site}: "
                f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''} "
                "(no network, or the archive is unreachable)"
            ) from None
        for name in names:
            leaf = str(name).rstrip("/").rsplit("/", 1)[-1]
            m = _NAME.match(leaf)
            if m and m["site"] == site:
                t = datetime.strptime(m["ymd"] + m["hms"], "%Y%m%d%H%M%S")
                out.append(Volume(f"{day:%Y/%m/%d}/{site}/{leaf}", t.replace(tzinfo=timezone.utc)))
    return sorted(out, key=lambda v: v.time)


def nearest_volume(site: str, when: datetime) -> Volume:
    site = site.upper()
    if not re.fullmatch(r"[A-Z0-9]{4}", site):
        raise ValueError(f"expected a four-letter radar identifier such as KTLX, found {site!r}")
    found = volumes_near(site, when)
    if not found:
        raise ArchiveError(
            f"{archive_root()} holds no Level-II volume of {site} within a day of "
            f"{when:%Y-%m-%dT%H:%MZ}"
        )
    best = min(found, key=lambda v: abs(v.time - when))
    if abs(best.time - when) > MAX_OFFSET:
        raise ArchiveError(
            f"{archive_root()} holds no {site} volume within {MAX_OFFSET.seconds // 60} min of "
            f"{when:%Y-%m-%dT%H:%MZ} (the nearest is {best.time:%Y-%m-%dT%H:%M:%SZ})"
        )
    return best


def fetch(site: str, when: datetime, cache: Path) -> Path:
    """The local path of the volume nearest ``when``, downloaded into ``cache`` if needed."""
    volume = nearest_volume(site, when)
    local = cache / volume.key
    if local.is_file():
        return local
    local.parent.mkdir(parents=True, exist_ok=True)
    fs, base = _filesystem(archive_root())
    partial = local.with_name(local.name + ".partial")
    try:
        fs.get(f"{base}/{volume.key}", str(partial))
        partial.replace(local)
    except Exception as exc:
        partial.unlink(missing_ok=True)
        raise ArchiveError(
            f"cannot download {archive_root()}/{volume.key}: {type(exc).__name__}: "
            f"{str(exc).splitlines()[0] if str(exc) else ''}"
        ) from None
    return local
