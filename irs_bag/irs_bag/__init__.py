"""MCAP bags of the IRS graph: write, read, recover, validate; the recorder and the bag tools.

The public face::

    from irs_bag import BagReader, BagWriter, BagError, recover, validate

Library modules: :mod:`.writer` (rosbag2-compatible MCAP with CRCs and indexes),
:mod:`.reader` (indexed reads; unfinished or damaged bags read as far as intact),
:mod:`.layout` (a bag on disk), :mod:`.scan` (sequential scan for recovery), :mod:`.validation`,
:mod:`.recovery`, :mod:`.msg_definitions`, :mod:`.run_series` (a run's arrays by stamp). The
node :mod:`.recorder_node` (``recorder``, parameters in :mod:`.recorder_params`). The tools
behind ``bag`` (:mod:`.cli`): info, export, play, plots, rerun, recover, validate.
"""
from .reader import BagReader, recover
from .scan import BagError
from .validation import ValidationReport, validate
from .writer import BagWriter

__all__ = ['BagError', 'BagReader', 'BagWriter', 'ValidationReport', 'recover', 'validate']
