"""``bag recover <bag> [--out DIR]``: a valid bag from an unfinished or damaged one (no rclpy).

The source is scanned sequentially (:func:`irs_bag.scan.recover`): every complete,
CRC-valid chunk up to the first damaged or missing record, whatever state the summary section
is in (a recorder killed with SIGKILL leaves none). Its messages are written with
:class:`irs_bag.writer.BagWriter` into ``DIR`` (default ``<bag>_recovered`` beside
the source): an MCAP file with summary and indexes plus ``metadata.yaml``, as the recorder
writes. Kept: bytes, log and publish times [ns], sequence numbers, topics with their types,
stored definitions, QoS and type hashes, metadata records (the source's ``rosbag2`` record is
replaced by the new one), drop counts from a usable source ``metadata.yaml``. Added: a
metadata record ``irs_recovered`` (source, messages, chunks, why the scan stopped).

One line on stdout says what was recovered. Exit codes: 0 written; 2 not a bag, unreadable,
output not writable or usage error (one line on stderr).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import List, Optional

from .layout import resolve_bag as _resolve
from .scan import BagError, recover
from .writer import BagWriter, BagWriterError
from .msg_definitions import MessageDefinitionError

__all__ = ['recover_bag', 'main']


def default_output(bag: Path) -> Path:
    """``<bag>_recovered`` beside the source (``run.mcap`` -> ``run_recovered``)."""
    return bag.with_name((bag.stem if bag.suffix == '.mcap' else bag.name) + '_recovered')


def recover_bag(bag, out=None) -> dict:
    """Write the recoverable part of ``bag`` as a new bag ``out``; return a summary dict.

    Keys: ``out``, ``messages``, ``topics``, ``chunks``, ``duration_s``, ``complete``,
    ``error`` (why the scan stopped, or None), ``skipped`` (messages of untyped channels).

    Raises
    ------
    BagError
        The source is not a bag / unreadable, or the output cannot be written.
    """
    warnings: List[str] = []
    src, files, meta = _resolve(bag, warnings)
    rec = recover(src, files)
    out = Path(out) if out is not None else default_output(src)
    skipped = 0
    try:
        with BagWriter(out) as w:
            for name, data in rec.metadata:
                if name != 'rosbag2':
                    w.add_metadata(name, data)
            w.add_metadata('irs_recovered', {
                'source': str(src), 'messages': str(len(rec)), 'chunks': str(rec.chunks),
                'stopped_at': rec.error or '', 'warnings': '; '.join(warnings)})
            for scan in rec.scans:
                for ch in scan.channels.values():
                    sc = scan.schemas.get(ch.schema_id)
                    if sc is None or not sc.name:
                        continue
                    w.add_topic(ch.topic, sc.name, ch.metadata.get('offered_qos_profiles', ''),
                                ch.metadata.get('topic_type_hash', ''),
                                definition=sc.data.decode('utf-8', 'replace'))
                for m, (pub, seq) in zip(scan.messages, scan.extras):
                    if not m.type:
                        skipped += 1
                        continue
                    w.write(m.topic, m.type, m.data, m.log_time_ns, pub, seq)
            _carry_drops(w, meta)
            s = w.close()
    except (BagWriterError, MessageDefinitionError, OSError) as exc:
        raise BagError(f'cannot write {out}: {exc}') from None
    return {'out': out, 'messages': s.message_count, 'topics': len(s.topics),
            'chunks': rec.chunks, 'duration_s': s.duration_ns * 1e-9,
            'complete': rec.complete, 'error': rec.error, 'skipped': skipped}


def _carry_drops(w: BagWriter, meta: Optional[dict]) -> None:
    """Drop counts of the source's metadata.yaml (if any) go into the new one."""
    custom = (meta or {}).get('custom_data')
    try:
        per = json.loads(custom.get('irs.dropped_messages_per_topic', '{}'))
        for topic, n in per.items():
            if isinstance(n, int) and n > 0:
                w.record_drop(str(topic), n)
    except (AttributeError, TypeError, ValueError):
        pass


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``bag recover``; returns the exit code."""
    p = argparse.ArgumentParser(prog='bag recover',
                                description='Write a valid bag from an unfinished or damaged one.')
    p.add_argument('bag', help='bag directory or .mcap file')
    p.add_argument('--out', metavar='DIR', help='new bag directory (default <bag>_recovered)')
    args = p.parse_args(argv)
    try:
        r = recover_bag(args.bag, args.out)
    except BagError as exc:
        print(f'bag recover: error: {exc}', file=sys.stderr)
        return 2
    lost = ('the source was complete' if r['complete'] else
            f"the rest is lost (the scan stopped at: {r['error']})")
    skipped = f", {r['skipped']} untyped messages skipped" if r['skipped'] else ''
    print(f"bag recover: {r['out']}: {r['messages']} messages on {r['topics']} topics, "
          f"{r['duration_s']:.3f} s, from {r['chunks']} complete chunks of {args.bag}"
          f"{skipped}; {lost}", flush=True)
    return 0


if __name__ == '__main__':  # pragma: no cover
    sys.exit(main())
