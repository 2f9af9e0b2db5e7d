"""The runner stops the nodes first with the node grace, then whatever records, with the
recorder's grace: the recorder alone, or a container that holds it (a composed run's recorder
closes its bag then). ``ExperimentRunner._stop_all`` on a stand-in runner, the processes not
started: ``stop_processes`` is recorded instead.
"""
from types import SimpleNamespace

from irs_bringup import experiment_runner as er


def test_a_container_holding_the_recorder_gets_the_recorders_grace(monkeypatch):
    calls = []
    monkeypatch.setattr(er, 'stop_processes', lambda procs, grace: calls.append(
        ([p.label for p in procs], grace)) or {p.label: 0 for p in procs})
    procs = {k: SimpleNamespace(label=k, escalated_to=None) for k in ('graph', 'rig', 'recorder')}
    runner = SimpleNamespace(procs=procs, devices={}, log=print,
                             members={'graph': ['vehicle_sim', 'recorder'], 'rig': ['x']})
    runner._holds_recorder = lambda label: er.ExperimentRunner._holds_recorder(runner, label)
    codes = er.ExperimentRunner._stop_all(runner)
    assert calls == [(['rig'], er.NODE_GRACE), (['graph', 'recorder'], er.RECORDER_GRACE)]
    assert codes == {'rig': 0, 'graph': 0, 'recorder': 0}
