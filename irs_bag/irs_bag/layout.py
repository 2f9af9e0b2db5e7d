"""A bag on disk: a rosbag2 directory (``metadata.yaml`` + ``*.mcap``) or one ``.mcap`` file.

:func:`resolve_bag` finds the MCAP files of a bag (from its ``metadata.yaml``, or the
directory's ``*.mcap`` files when that is unusable) and :func:`unfinished_reason` tells a
closed MCAP file from one its writer did not close. The reader, the validator and
recovery all start here. No rclpy.
"""
from __future__ import annotations

import io
import os
from pathlib import Path
from typing import List, Optional, Tuple, Union

import yaml
from mcap.records import DataEnd, Footer
from mcap.stream_reader import StreamReader

from .errors import BagError, one_line as _one_line
from .scan import MAGIC

#: Bytes of an MCAP footer record: opcode, length, summary_start, summary_offset_start, crc.
FOOTER_LEN = 1 + 8 + 8 + 8 + 4
#: Bytes of an MCAP DataEnd record: opcode, length, data_section_crc.
DATA_END_LEN = 1 + 8 + 4

PathLike = Union[str, os.PathLike]


def read_metadata_yaml(meta_path: Path) -> dict:
    """The ``rosbag2_bagfile_information`` mapping; ValueError (one line) if unusable."""
    try:
        text = meta_path.read_bytes().decode('utf-8')
    except UnicodeDecodeError as exc:
        raise ValueError(f'not UTF-8 (byte {exc.start})') from None
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ValueError(f'not YAML ({_one_line(exc, 120)})') from None
    meta = doc.get('rosbag2_bagfile_information') if isinstance(doc, dict) else None
    if not isinstance(meta, dict):
        raise ValueError('no rosbag2_bagfile_information mapping')
    paths = meta.get('relative_file_paths')
    if not isinstance(paths, list) or not all(isinstance(x, str) and x for x in paths):
        raise ValueError('relative_file_paths is not a list of file names')
    return meta


def resolve_bag(path: PathLike, warnings: Optional[List[str]] = None
             ) -> Tuple[Path, List[Path], Optional[dict]]:
    """(bag path, mcap files, rosbag2_bagfile_information or None).

    ``path``: a bag directory, an ``.mcap`` file, or a run's directory (``runs/<run>``: the
    bag is its ``bag`` directory). An unusable metadata.yaml is ignored (one line appended to
    ``warnings``, or a :class:`BagError` if ``warnings`` is None) and the directory's
    ``*.mcap`` files are used.
    """
    p = Path(path)
    if not p.exists():
        raise BagError(f'{p}: no such bag directory or file')
    if not p.is_dir():
        if p.suffix != '.mcap':
            raise BagError(f'{p}: expected a bag directory or a .mcap file')
        return p, [p], None
    meta_path = p / 'metadata.yaml'
    meta, files, problem = None, [], None
    if meta_path.is_file():
        try:
            meta = read_metadata_yaml(meta_path)
            files = [p / Path(x).name for x in meta['relative_file_paths']]
            missing = [f.name for f in files if not f.is_file()]
            bad = [f.name for f in files if f.suffix != '.mcap']
            if missing:
                raise ValueError(f'lists missing files {missing}')
            if bad:
                raise ValueError(f'lists non-MCAP files {bad} (only MCAP storage is supported)')
        except (OSError, ValueError) as exc:
            why = exc if isinstance(exc, ValueError) else _one_line(exc)
            problem = f'{meta_path}: unusable metadata.yaml ({why})'
            meta, files = None, []
    if not files:
        files = sorted(p.glob('*.mcap'))
        if not files and problem is None and (p / 'bag').is_dir():
            return resolve_bag(p / 'bag', warnings)     # a run's directory: its bag
        if not files:
            raise BagError(problem or f'{p}: no metadata.yaml and no .mcap file in this directory')
    if problem:
        if warnings is None:
            raise BagError(problem)
        warnings.append(f'{problem}; ignored it and read {", ".join(f.name for f in files)}')
    return p, files, meta


def unfinished_reason(path: Path) -> Optional[str]:
    """Why the MCAP file ``path`` is unfinished (its writer did not close it), None if closed.

    Closed: the MCAP magic at both ends, a footer before the closing one, and (when the footer
    names no summary) a ``DataEnd`` record before the footer. An open :class:`BagWriter` file
    ends with a footer but no ``DataEnd`` (its provisional tail); a killed one may end anywhere.

    Raises
    ------
    BagError
        Not an MCAP file (bad magic) or not readable.
    """
    try:
        size = path.stat().st_size
        with open(path, 'rb') as f:
            if f.read(8) != MAGIC:
                raise BagError(f'{path}: not an MCAP file (bad magic)')
            if size < 16 + FOOTER_LEN:
                return 'cut off before its footer'
            f.seek(-8, io.SEEK_END)
            if f.read(8) != MAGIC:
                return 'no MCAP footer: cut off'
            footer = record_at(f, size - 8 - FOOTER_LEN, size)
            if not isinstance(footer, Footer):
                return None      # a damaged footer: a closed file with a damaged end
            if footer.summary_start:
                return None
            before = record_at(f, size - 8 - FOOTER_LEN - DATA_END_LEN, size)
            return None if isinstance(before, DataEnd) else 'no DataEnd record, no summary'
    except OSError as exc:
        raise BagError(f'{path}: cannot read ({_one_line(exc)})') from None


def record_at(f, offset: int, size: int):
    """The MCAP record at byte ``offset`` of the open file ``f`` of ``size`` bytes (read with
    mcap's ``StreamReader``), or None if no record can be read there.
    """
    if offset < 8:
        return None
    f.seek(offset)
    try:
        return next(StreamReader(f, skip_magic=True, record_size_limit=size).records)
    except Exception:
        return None
