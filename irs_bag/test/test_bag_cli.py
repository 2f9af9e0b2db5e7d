"""``bag`` runs through ``irs_common.cli.run_cli``: one line and the documented exit code for
what escapes a verb (docs/cli.md).
"""
import pytest

from irs_bag import cli
from irs_bag.errors import BagError


@pytest.mark.parametrize('exc, code, line', [
    (BagError('x.mcap: not an MCAP file'), 2, 'bag: error: x.mcap: not an MCAP file'),
    (RuntimeError('boom'), 70, 'bag: internal error: RuntimeError: boom; this is a bug'),
    (KeyboardInterrupt(), 130, 'bag: interrupted (SIGINT)'),
])
def test_what_escapes_a_verb_is_one_line_and_its_code(monkeypatch, capsys, exc, code, line):
    import irs_bag.info

    def verb(_argv):
        raise exc
    monkeypatch.setattr(irs_bag.info, 'main', verb)
    assert cli.main(['info', 'x.mcap']) == code
    err = capsys.readouterr().err
    assert err.startswith(line) and err.count('\n') == 1, err


def test_unknown_verb_and_no_verb_are_usage_errors(capsys):
    assert cli.main(['frobnicate']) == 2
    err = capsys.readouterr().err
    assert err.startswith("bag: error: unknown command 'frobnicate'") and err.count('\n') == 1
    assert cli.main([]) == 2
