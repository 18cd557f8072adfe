"""The algorithm registry: every family's labels, described and ordered for clients."""

import re

import pytest

from mgrao_core import PRESETS, ConfigError
from mgrao_core.algorithms import FAMILIES, PALETTE_SLOTS, describe_label, parse_algorithm, registry, sort_key


def test_describe_canonicalises_and_names_the_family():
    described = describe_label(" MGRAO-05:1 ", PRESETS["large"].params)
    assert described["label"] == "mgrao-5:1"
    assert described["family"] == "mgrao"
    assert described["groups"] == 5
    assert describe_label("uniform")["groups"] is None
    assert describe_label("mgrao-max", PRESETS["single"].params)["groups"] == 10


def test_describe_without_a_system_checks_the_grammar_only():
    assert describe_label("mgrao-7:1")["label"] == "mgrao-7:1"  # no n_parents to divide
    with pytest.raises(ConfigError) as info:
        describe_label("mgrao-7:1", PRESETS["single"].params)
    assert info.value.field == "label"
    assert "valid: 1, 2, 5, 10" in info.value.message
    with pytest.raises(ConfigError) as info:
        describe_label("greedy")
    assert "unknown algorithm" in info.value.message


@pytest.mark.parametrize("system", list(PRESETS))
def test_the_configurations_of_every_paper_system_have_their_own_colour(system):
    labels = list(dict.fromkeys([*PRESETS[system].algorithms, "oracle"]))  # (cloud's own algorithms have the oracle)
    keys = [describe_label(label, PRESETS[system].params)["colour_key"] for label in labels]
    assert len(set(keys)) == len(keys), dict(zip(labels, keys, strict=True))
    assert all(0 <= key < PALETTE_SLOTS for key in keys)


def test_sort_order_is_uniform_then_ratios_by_x_then_max_then_oracle():
    labels = ["oracle", "mgrao-max", "mgrao-10:1", "uniform", "mgrao-2:1", "mgrao-1:1", "unknown-thing"]
    assert sorted(labels, key=sort_key) == ["uniform", "mgrao-1:1", "mgrao-2:1", "mgrao-10:1", "mgrao-max",
                                           "oracle", "unknown-thing"]


def test_registry_examples_are_valid_for_the_system_and_match_their_forms():
    for preset in PRESETS.values():
        n_parents = preset.params.n_parents
        entries = registry(preset.params)
        assert [e["name"] for e in entries] == [f.name for f in FAMILIES]
        for entry in entries:
            for label in entry["examples"]:
                assert parse_algorithm(label, n_parents).kind == entry["name"]
                assert any(re.fullmatch(form["pattern"], label) for form in entry["forms"]), label
            for form in entry["forms"]:
                if form["argument"]:
                    for x in form["valid"]:
                        for y in form.get("second_valid", [1]):  # a form of two arguments: every valid pair
                            label = form["template"].replace("{" + form["argument"] + "}", str(x))
                            label = label.replace("{" + str(form.get("second_argument")) + "}", str(y))
                            algorithm = parse_algorithm(label, n_parents, n_children=preset.params.n_children)
                            assert algorithm.kind == entry["name"]
                            assert re.fullmatch(form["pattern"], label), label


def test_every_paper_label_is_an_example_or_matches_a_form():
    for preset in PRESETS.values():
        entries = registry(preset.params)
        patterns = [form["pattern"] for entry in entries for form in entry["forms"]]
        for label in preset.algorithms:
            assert any(re.fullmatch(p, label) for p in patterns), label


NEAR = ({1, 6}, {2, 5})  # palette slots of the two blues and of the two oranges (frontend/js/colours.js)


@pytest.mark.parametrize("labels", [
    ["uniform", "mgrao-1:1", "mgrao-2:1", "mgrao-5:1", "mgrao-10:1", "mgrao-max"],
    ["uniform", "mgrao-2:1", "mgrao-5:1", "mgrao-10:1", "mgrao-max", "oracle"],
])
def test_configurations_shown_together_in_the_paper_systems_differ_in_hue(labels):
    # Seven configurations cannot: the palette has six hues. The oracle is the lighter blue beside
    # 1:1's darker one, and large's 25:1 the orange beside max's vermillion.
    keys = {describe_label(label)["colour_key"] for label in labels}
    assert not any(pair <= keys for pair in NEAR), keys
