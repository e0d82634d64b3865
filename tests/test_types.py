"""vs_inspect.types: the text helpers of the result types."""

from __future__ import annotations

from vs_inspect.types import first_clause, pairs_by_reason


def test_pairs_sharing_a_reason_are_named_together_once():
    items = [("a__b", "no cross-view track pairs"), ("a__c", "too few track pairs: only 3"),
             ("a__d", "no cross-view track pairs"), ("a__e", "no cross-view track pairs")]
    assert pairs_by_reason(items) == ["a__b, a__d and a__e: no cross-view track pairs",
                                      "a__c: too few track pairs: only 3"]
    assert pairs_by_reason(items[:2], " got nothing") == ["a__b got nothing: no cross-view track pairs",
                                                          "a__c got nothing: too few track pairs: only 3"]
    assert pairs_by_reason([]) == []


def test_many_pairs_with_one_reason_are_counted_past_the_first_few():
    items = [(f"a__v{i}", "same") for i in range(10)]
    assert pairs_by_reason(items, max_names=3) == ["a__v0, a__v1, a__v2 and 7 more: same"]
    assert pairs_by_reason(items[:3], max_names=3) == ["a__v0, a__v1 and a__v2: same"]


def test_a_reasons_first_clause_is_what_comes_before_its_details():
    assert first_clause("no reconstruction: too few matches (static background); from the moving points: ...") == (
        "no reconstruction: too few matches")
    assert first_clause("not connected to the reference 'cam0' through accepted pairs; its pairs: a__b: ...") == (
        "not connected to the reference 'cam0' through accepted pairs")
    assert first_clause("(a leading bracket is not a cut); then details") == "(a leading bracket is not a cut)"
    assert first_clause("no cross-view track pairs") == "no cross-view track pairs"
    cut = first_clause("x" * 300, max_chars=20)
    assert cut == "x" * 19 + "…" and len(cut) == 20
