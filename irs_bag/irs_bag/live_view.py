"""The live view's core: decoded messages of a running graph -> the entities of ``run.rrd``.

:class:`LiveFeed` holds, per topic suffix of :data:`irs_bag.rerun_entities.SPEC`, the fields the
entities are made of (the same field paths as the bag export, :class:`irs_bag.columns._Plan`),
and :meth:`LiveFeed.flush` sends what arrived since the last flush to a rerun recording stream
with :func:`irs_bag.rerun_entities.send`: one ``send_columns`` call per entity and batch, never
one log call per message. The car comes from ``ground_truth/odom`` once any arrived (else from
``pose``), as in ``run.rrd``. Timeline ``time``: seconds from the first ``header.stamp`` the feed
saw (sim time in lock-step runs), so a live recording lines up with ``run.rrd`` to within the
first messages a late viewer missed. No rclpy here: :mod:`irs_bag.live_view_node` feeds it.
"""
from __future__ import annotations

from typing import Dict, Optional

import numpy as np

from .columns import Columns, _Plan
from .rerun_entities import SPEC, log_static, send
from .run_info import RunInfo

__all__ = ['LiveFeed', 'open_stream', 'viewer_problem']

#: Topics drawn in the 3-D view (decimated to ``view_rate``); the others are series.
VIEW_SUFFIXES = ('ground_truth/odom', 'pose', 'arm/joint_states')


class LiveFeed:
    """Batches of the entities' columns from decoded messages (no rclpy, no rerun state)."""

    def __init__(self, info: RunInfo, *, view_rate: float = 30.0, series_rate: float = 0.0):
        self.info = info
        self.view_rate = float(view_rate)       # [Hz] 3-D entities (rerun_entities.decimate)
        self.series_rate = float(series_rate)   # [Hz] series (0 = every message fed)
        self.t0: Optional[float] = None         # [s] first stamp seen
        self._plans: Dict[str, _Plan] = {s: _Plan(cols) for s, cols in SPEC.items()}
        self.fed = 0                             # messages fed in all
        self.odom_seen = False                   # the car then comes from odometry alone
        self._last_bin: Dict[str, float] = {}    # per suffix: decimation bin last sent

    def add(self, suffix: str, msg, recv_ns: int = 0) -> None:
        """Keep ``msg`` (a message of the topic ``suffix`` of SPEC), received at ``recv_ns``."""
        self._plans[suffix].take(msg, recv_ns)
        self.fed += 1
        self.odom_seen = self.odom_seen or suffix == 'ground_truth/odom'

    def take(self) -> Columns:
        """The columns fed since the last take (rows with a non-finite stamp dropped)."""
        out: Columns = {}
        for suffix, plan in self._plans.items():
            if not plan.rows:
                continue
            cols = plan.columns()
            plan.rows, plan.log_ns = [], []
            good = np.isfinite(cols['t'])
            if good.any():
                out[suffix] = {c: v[good] for c, v in cols.items()}
        return out

    def flush(self, rec) -> Dict[str, int]:
        """Send the batch to ``rec`` (a ``rerun.RecordingStream``); rows sent per entity."""
        columns = self.take()
        if self.odom_seen:      # as run.rrd: the car from odometry, not from a batch's pose
            columns.pop('pose', None)
        if not columns:
            return {}
        if self.t0 is None:
            self.t0 = float(min(c['t'][0] for c in columns.values()))
        columns = {s: c for s, c in ((s, self._decimate(s, c)) for s, c in columns.items())
                   if len(c['t'])}
        return send(rec, columns, self.t0, self.info, view_rate=self.view_rate,
                    series_rate=self.series_rate)

    def _decimate(self, suffix: str, cols: Dict[str, np.ndarray]) -> Dict[str, np.ndarray]:
        """The first row of every ``1/rate`` s bin from ``t0`` not sent in an earlier batch
        (a batch may hold less than one bin: a lock-step run slower than real time).
        """
        rate = self.view_rate if suffix in VIEW_SUFFIXES else self.series_rate
        if rate <= 0:
            return cols
        bins = np.floor((cols['t'] - self.t0) * rate + 1e-9)
        prev = np.r_[self._last_bin.get(suffix, -np.inf), bins[:-1]]
        keep = bins != prev
        self._last_bin[suffix] = bins[-1]
        return {c: v[keep] for c, v in cols.items()}


def open_stream(info: RunInfo, *, url: str = '', save: str = '', application_id: str = 'irs'):
    """A recording stream to a viewer at ``url`` (rerun's gRPC proxy), or to the ``.rrd`` file
    ``save`` when given, with the default layout and the static entities logged.

    Raises
    ------
    OSError, RuntimeError
        The file cannot be created, or the URL is not a rerun gRPC URL.
    """
    import rerun as rr
    from .rerun_entities import blueprint
    rec = rr.RecordingStream(application_id)
    if save:
        rec.save(save, default_blueprint=blueprint())
    else:
        rec.connect_grpc(url or None, default_blueprint=blueprint())
    log_static(rec, info)
    return rec


def viewer_problem(url: str, timeout: float = 1.0) -> Optional[str]:
    """Why nothing receives a stream to a rerun viewer at ``url``
    (``rerun+http://host:port/proxy``), or None: nothing listens on its TCP port (``'no rerun
    viewer listens at host:port (Connection refused)'``), or its port is not a number.

    rerun's ``connect_grpc`` does not fail then: it keeps the recording in memory, retries, and
    at the end waits 5 s more for a viewer before dropping it. Callers say what to do.
    """
    import socket
    from urllib.parse import urlsplit
    parts = urlsplit(url)
    try:
        host, port = parts.hostname or '127.0.0.1', parts.port or 9876
    except ValueError as exc:
        return f'{url}: {exc}'
    try:
        with socket.create_connection((host, port), timeout=timeout):
            return None
    except OSError as exc:
        return f'no rerun viewer listens at {host}:{port} ({exc.strerror or type(exc).__name__})'
