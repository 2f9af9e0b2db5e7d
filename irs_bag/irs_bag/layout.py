"""A bag on disk: a rosbag2 directory (``metadata.yaml`` + ``*.mcap``) or one ``.mcap`` file.

:func:`resolve_bag` finds the MCAP files of a bag (from its ``metadata.yaml``, or the
directory's ``*.mcap`` files when that is unusable) and :func:`check_complete` tells a closed
MCAP file (magic at both ends, a footer) from an unfinished one. The reader, the validator and
recovery all start here. No rclpy.
"""
from __future__ import annotations

import io
import os
from pathlib import Path
from typing import List, Optional, Tuple, Union

import yaml

from .scan import MAGIC, BagError, one_line as _one_line

#: Bytes of an MCAP footer record: opcode, length, summary_start, summary_offset_start, crc.
FOOTER_LEN = 1 + 8 + 8 + 8 + 4

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

    An unusable metadata.yaml is ignored (one line appended to ``warnings``, or a
    :class:`BagError` if ``warnings`` is None) and the directory's ``*.mcap`` files are used.
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
        if not files:
            raise BagError(problem or f'{p}: no metadata.yaml and no .mcap file in this directory')
    if problem:
        if warnings is None:
            raise BagError(problem)
        warnings.append(f'{problem}; ignored it and read {", ".join(f.name for f in files)}')
    return p, files, meta


def check_complete(path: Path) -> None:
    """BagError unless ``path`` starts with the MCAP magic and ends with a footer + magic."""
    try:
        size = path.stat().st_size
        with open(path, 'rb') as f:
            head = f.read(8)
            if size >= 16:
                f.seek(-8, io.SEEK_END)
            tail = f.read(8)
    except OSError as exc:
        raise BagError(f'{path}: cannot read ({_one_line(exc)})') from None
    if head != MAGIC:
        raise BagError(f'{path}: not an MCAP file (bad magic)')
    if size < 16 + FOOTER_LEN or tail != MAGIC:
        raise BagError(f'{path}: truncated or not closed (no MCAP footer); '
                       f'`bag recover` / irs_bag.recover() give back its complete chunks')
