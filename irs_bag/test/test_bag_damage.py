"""Damaged and unfinished bags: every verb gives a result or one line (exit 2), never a traceback;
``bag recover`` writes a valid bag from them.
"""
import contextlib
import io
import random
import shutil
import struct

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from irs_bag import (cli as bag_cli, export as bag_export, info as bag_info, play as bag_play,
                     plots as bag_plots, recovery as bag_recover, rerun_export)
from irs_bag import BagError, BagReader, validate
from irs_bag.writer import BagWriter

TS = get_typestore(Stores.ROS2_JAZZY)
G = TS.types
JS, PS = 'sensor_msgs/msg/JointState', 'geometry_msgs/msg/PointStamped'
N = 60
T0 = 10**18


def _time(ns):
    return G['builtin_interfaces/msg/Time'](sec=ns // 10**9, nanosec=ns % 10**9)


def make_bag(path, n=N, chunk_size=1024):
    """n joint states + n points (plots and rerun use them), small chunks, an experiment
    metadata record; stamps k ms, log times T0 + 3k ms.
    """
    with BagWriter(path, chunk_size=chunk_size) as w:
        w.add_metadata('irs_experiment', {'experiment_yaml': 'clock: realtime\n'})
        for k in range(n):
            hdr = G['std_msgs/msg/Header'](stamp=_time(k * 10**6), frame_id='t')
            js = G[JS](header=hdr, name=['a', 'b', 'c'],
                       position=np.array([0.1, -0.2 + 1e-3 * k, 0.3]),
                       velocity=np.zeros(0), effort=np.zeros(0))
            w.write('/arm/joint_states', JS, bytes(TS.serialize_cdr(js, JS)), T0 + 3 * k * 10**6)
            p = G[PS](header=hdr, point=G['geometry_msgs/msg/Point'](x=0.1, y=1e-3 * k, z=0.0))
            w.write('/ground_truth/sensor_point', PS, bytes(TS.serialize_cdr(p, PS)),
                    T0 + 3 * k * 10**6 + 1000)
    return path


@pytest.fixture(scope='module')
def small_bag(tmp_path_factory):
    return make_bag(tmp_path_factory.mktemp('damage') / 'bag')


def run_verb(verb, bag, work):
    """(exit code, stdout, stderr) of a verb's main, in this process: an exception escapes."""
    calls = {
        'info': lambda: bag_info.main([bag]),
        'validate': lambda: bag_cli._validate([bag]),
        'export': lambda: bag_export.main([bag, '--out', f'{work}/csv']),
        'play': lambda: bag_play.main([bag, '--dry-run']),
        'recover': lambda: bag_recover.main([bag, '--out', f'{work}/recovered']),
        'plots': lambda: bag_plots.main([bag, '--out', f'{work}/plots']),
        'rerun': lambda: rerun_export.main([bag, '--out', f'{work}/run.rrd']),
    }
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = calls[verb]()
    return code, out.getvalue(), err.getvalue()


def _summary_start(data):
    return struct.unpack_from('<Q', data, len(data) - 8 - 29 + 9)[0]


def test_byte_flips_give_a_result_or_one_line(small_bag, tmp_path):
    """Single byte flips over a bounded sample of positions (every summary/footer byte region
    and the data section, seeded): each verb exits 0 (with at most one warning line) or 2
    (one error line naming the file); validate exits 1 (problems found) for a flip anywhere
    before the closing magic, data section included. Plots and rerun (slow) on a few positions.
    """
    mcap = next(small_bag.glob('*.mcap'))
    data = mcap.read_bytes()
    s_start = _summary_start(data)
    rnd = random.Random(20261126)
    positions = sorted(set(rnd.sample(range(s_start, len(data)), 30)
                           + rnd.sample(range(0, s_start), 20) + [0, 40, len(data) - 20]))
    slow = set(positions[::10])
    summary_fallbacks = 0
    for pos in positions:
        work = tmp_path / f'p{pos}'
        bag = work / 'bag'
        bag.mkdir(parents=True)
        flipped = bytearray(data)
        flipped[pos] ^= 0xFF
        (bag / mcap.name).write_bytes(bytes(flipped))
        shutil.copy(small_bag / 'metadata.yaml', bag / 'metadata.yaml')
        verbs = ['info', 'validate', 'export', 'play', 'recover'] + (
            ['plots', 'rerun'] if pos in slow else [])
        for verb in verbs:
            code, out, err = run_verb(verb, str(bag), work)
            lines = err.strip().splitlines()
            where = (pos, verb, code, err)
            assert 'Traceback' not in out + err, where
            assert code in ((0, 1, 2) if verb == 'validate' else (0, 2)), where
            assert len(lines) <= 1, where
            if code == 2:
                assert len(lines) == 1 and ('bag' in lines[0] and 'error' in lines[0]), where
                assert str(bag) in lines[0] or 'MCAP' in lines[0], where
            if verb == 'validate' and pos < len(data) - 8:
                # every byte before the closing magic is covered by a CRC (chunk, data
                # section, summary) or is structure the pass parses: the damage is found
                assert code == 1, where
            if verb == 'info' and code == 0 and pos >= s_start and 'data section' in err:
                summary_fallbacks += 1
                assert 'Messages:     120' in out, where   # the whole data section was read
    # the summary positions that still read were read from the data section instead
    assert summary_fallbacks >= 10


def test_unfinished_bag_every_verb_on_its_prefix(small_bag, tmp_path):
    """A copy cut in the middle (as a killed recorder leaves it): every verb reads the complete
    chunks with one warning line; recover writes a valid bag with exactly those messages.
    """
    mcap = next(small_bag.glob('*.mcap'))
    data = mcap.read_bytes()
    bag = tmp_path / 'cut'
    bag.mkdir()
    (bag / 'cut_0.mcap').write_bytes(data[:len(data) // 2])     # no metadata.yaml either
    with pytest.raises(BagError, match='recover'):
        BagReader(bag)
    with BagReader(bag, allow_partial=True) as r:
        prefix = [m for m in r.messages()]
    assert 10 < len(prefix) < 2 * N
    for verb in ('info', 'export', 'play', 'plots', 'rerun'):
        code, out, err = run_verb(verb, str(bag), tmp_path / verb)
        assert code == 0, (verb, err)
        lines = err.strip().splitlines()
        assert len(lines) == 1 and 'warning' in lines[0] and 'unfinished' in lines[0], (verb, err)
        assert 'Traceback' not in out + err
    # validate reads the same prefix but fails the bag, naming the way out
    code, out, err = run_verb('validate', str(bag), tmp_path / 'validate')
    lines = err.strip().splitlines()
    assert code == 1 and len(lines) == 1, err
    assert 'unfinished' in lines[0] and '`bag recover`' in lines[0], lines
    assert f'{len(prefix)} messages' in lines[0], lines
    code, out, err = run_verb('recover', str(bag), tmp_path)
    assert code == 0 and not err, err
    assert len(out.strip().splitlines()) == 1 and f'{len(prefix)} messages' in out, out
    rec = tmp_path / 'recovered'
    rep = validate(rec)
    assert rep.ok and rep.complete and rep.message_count == len(prefix), rep.problems
    with BagReader(rec) as r:
        assert not r.warnings
        assert [tuple(m) for m in r.messages()] == [tuple(m) for m in prefix]
        names = dict(r.metadata_records())
        assert names['irs_experiment'] == {'experiment_yaml': 'clock: realtime\n'}
        assert names['irs_recovered']['messages'] == str(len(prefix))
        with BagReader(small_bag) as orig:
            assert r.schemas == orig.schemas
            assert {t: i.offered_qos_profiles for t, i in r.topics.items()} == \
                {t: i.offered_qos_profiles for t, i in orig.topics.items()}
    # the default output is <bag>_recovered; an existing non-empty output is one line, exit 2
    assert bag_recover.main([str(bag)]) == 0 and validate(tmp_path / 'cut_recovered').ok
    code, out, err = run_verb('recover', str(bag), tmp_path)
    assert code == 2 and len(err.strip().splitlines()) == 1 and 'not empty' in err


def test_recover_keeps_a_whole_bag_whole(small_bag, tmp_path):
    code, out, err = run_verb('recover', str(small_bag), tmp_path)
    assert code == 0 and 'the source was complete' in out, (out, err)
    with BagReader(small_bag) as a, BagReader(tmp_path / 'recovered') as b:
        assert [tuple(m) for m in a.messages()] == [tuple(m) for m in b.messages()]
        assert b.message_count == 2 * N


@pytest.mark.parametrize(
    'content',
    [b'\xff\xfe not utf-8 \x80\n', b'rosbag2_bagfile_information: [', b'just a string',
     b'rosbag2_bagfile_information:\n  relative_file_paths: [missing_0.mcap]\n'],
)
def test_bad_metadata_yaml_is_one_line_and_the_mcap_still_reads(small_bag, tmp_path, content):
    bag = tmp_path / 'bag'
    shutil.copytree(small_bag, bag)
    (bag / 'metadata.yaml').write_bytes(content)
    for verb in ('info', 'export', 'play'):
        code, out, err = run_verb(verb, str(bag), tmp_path / verb)
        lines = err.strip().splitlines()
        assert code == 0 and len(lines) == 1, (verb, err)
        assert 'metadata.yaml' in lines[0] and 'warning' in lines[0]
    code, out, err = run_verb('info', str(bag), tmp_path)
    assert 'Messages:     120' in out
    # validate reports it as a problem, and still checks the MCAP file
    rep = validate(bag)
    assert [p for p in rep.problems if 'metadata.yaml' in p] and rep.message_count == 2 * N
