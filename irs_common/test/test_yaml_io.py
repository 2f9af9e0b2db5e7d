"""irs_common.yaml_io: libyaml's parser gives the values of PyYAML's pure-Python safe loader."""
from pathlib import Path
import subprocess

from hypothesis import given, settings, strategies as st
import pytest
import yaml

from irs_common import yaml_io

ROOT = Path(__file__).resolve().parents[2]


def typed(value):
    """``value`` with every scalar's type beside it (``1 == 1.0 == True`` in plain ``==``)."""
    if isinstance(value, dict):
        return {typed(k): typed(v) for k, v in value.items()}
    if isinstance(value, list):
        return [typed(v) for v in value]
    return (type(value).__name__, repr(value))


def test_the_c_parser_is_the_one_in_use():
    assert yaml.__with_libyaml__, 'PyYAML without libyaml: the pure-Python parser is used'
    assert yaml_io.LOADER is yaml.CSafeLoader


def tree_yaml_files():
    out = subprocess.run(['git', 'ls-files', '*.yaml', '*.yml'], cwd=ROOT, capture_output=True,
                         text=True)
    return [ROOT / f for f in out.stdout.split()] if out.returncode == 0 else []


@pytest.mark.parametrize('path', tree_yaml_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_yaml_file_of_the_tree_gives_the_same_values(path):
    text = path.read_text()
    assert typed(yaml_io.safe_load(text)) == typed(yaml.safe_load(text))


def test_the_tree_has_yaml_files():
    assert len(tree_yaml_files()) >= 30


SCALARS = (st.none() | st.booleans() | st.integers(-2**70, 2**70)
           | st.floats(allow_nan=False) | st.text(max_size=20))
DOCS = st.recursive(SCALARS, lambda inner: st.lists(inner, max_size=4)
                    | st.dictionaries(st.text(max_size=8), inner, max_size=4), max_leaves=20)


@settings(max_examples=300, deadline=None)
@given(DOCS, st.booleans())
def test_any_dumped_document_loads_the_same(doc, flow):
    text = yaml.safe_dump(doc, default_flow_style=flow, allow_unicode=True)
    assert typed(yaml_io.safe_load(text)) == typed(yaml.safe_load(text))


@settings(max_examples=500, deadline=None)
@given(st.text(alphabet=st.sampled_from(list('ab01:-[]{},#\'"!&*?|>%@` \t\n.\x85\ufeffe')),
               max_size=40))
def test_any_text_gives_values_or_a_yaml_error(text):
    """Malformed text is a ``yaml.YAMLError`` (the one-line errors catch it), never another
    exception.

    Off the documents above the parsers differ (``irs_common/yaml_io.py``).
    """
    try:
        yaml_io.safe_load(text)
    except yaml.YAMLError:
        pass


def test_an_empty_node_with_a_bare_tag():
    assert yaml.safe_load('a: !') == {'a': None} and yaml_io.safe_load('a: !') == {'a': ''}


@pytest.mark.parametrize('text', ['a: [1, 2', 'a: b: c', '- a\nb: 1', 'a: !!python/tuple [1]'])
def test_bad_yaml_is_a_yaml_error(text):
    with pytest.raises(yaml.YAMLError):
        yaml_io.safe_load(text)


def test_a_params_file_with_a_tab_before_a_comment_reads_as_rcl_reads_it(tmp_path):
    """rcl's parameter parser (libyaml) accepts a tab before a comment, so the nodes' own check
    of ``--params-file`` reads it too (PyYAML's parser refuses it).
    """
    from irs_common.params import params_file_sections
    path = tmp_path / 'tab.yaml'
    path.write_text('vehicle_sim:\n  ros__parameters:\n    surface:\n      mu_left: 0.8\t# left\n')
    with pytest.raises(yaml.YAMLError):
        yaml.safe_load(path.read_text())
    assert params_file_sections(path) == {'vehicle_sim': {'surface.mu_left': 0.8}}
