"""The skill manager: routing outputs to inputs by name, dependency order, rates, enable/disable."""

from __future__ import annotations

import pytest

from atlas_rap.errors import AtlasError
from atlas_rap.lang import parse_term, parse_text
from atlas_rap.sequencer import Sequencer
from atlas_rap.skills import Skill, SkillManager
from atlas_rap.skills.catalog import STOCK_EVENTS, STOCK_SKILLS
from atlas_rap.skills.manager import dependency_order
from atlas_rap.skills.skill import HALTED


class Counter(Skill):
    """Counts its ticks and writes ``count``."""

    name = "counter"
    outputs = ("count",)
    always_on = True
    rate = 10.0

    def init(self, context) -> None:
        super().init(context)
        self.ticks = 0

    def transform(self, inputs):
        self.ticks += 1
        return {"count": self.ticks}


class Doubler(Skill):
    """Reads ``count``, writes ``double``; logs what it saw."""

    name = "doubler"
    params = ("label",)
    inputs = ("count",)
    outputs = ("double",)
    rate = 20.0

    def init(self, context) -> None:
        super().init(context)
        self.seen: list = []
        self.disabled = 0

    def transform(self, inputs):
        self.seen.append(inputs["count"])
        return {"double": None if inputs["count"] is None else 2 * inputs["count"]}

    def disable(self) -> None:
        self.disabled += 1


class Finisher(Skill):
    """Finishes after ``n`` ticks, failing with a reason when told to."""

    name = "finisher"
    params = ("n", "outcome")
    events = ("tick",)

    def enable(self, args) -> None:
        super().enable(args)
        self.left = int(args[0])

    def transform(self, inputs):
        self.left -= 1
        if self.left == 0:
            outcome = str(self.args[1])
            self.context.finish(self, outcome, "it was told to" if outcome == ":fail" else None)
        return {}


def test_skills_run_in_dependency_order_whatever_order_they_are_given():
    consumer, producer = Doubler(), Counter()
    assert [s.name for s in dependency_order([consumer, producer])] == ["counter", "doubler"]


def test_a_cycle_of_skills_is_an_error_naming_them():
    class A(Skill):
        name, inputs, outputs = "a", ("y",), ("x",)

    class B(Skill):
        name, inputs, outputs = "b", ("x",), ("y",)

    with pytest.raises(AtlasError, match="skills feed each other in a circle: a -> b -> a|b -> a -> b"):
        dependency_order([A(), B()])


def test_outputs_reach_inputs_by_name_each_skill_at_its_rate_and_disabling_clears_outputs():
    counter, doubler = Counter(), Doubler()
    manager = SkillManager([doubler, counter])
    Sequencer(skills=manager)  # connects the manager: init, always-on skills enabled
    call = parse_term("(doubler x)")
    manager.enable(call)
    for step in range(1, 5):  # 20 Hz ticks: 0.05, 0.10, 0.15, 0.20
        manager.tick(step * 0.05)
    assert counter.ticks == 3  # 10 Hz on its schedule from t=0: due at 0 (runs at 0.05), 0.1 and 0.2
    assert doubler.seen == [1, 2, 2, 3]  # it always sees the counter of this tick
    assert manager.data["double"] == 6
    manager.disable(call)  # Doubler's disable takes no reason, as skills written before it had one
    assert doubler.disabled == 1 and "double" not in manager.data
    manager.tick(0.25)
    assert doubler.seen == [1, 2, 2, 3]


def test_finishing_posts_done_and_why_and_the_sequencer_reports_the_reason():
    program = parse_text("(define-rap (work ?outcome) (retries 1) (method (task-net (t1 (finisher 3 ?outcome)))))"
                         ).forms
    manager = SkillManager([Finisher()])
    seq = Sequencer(program, skills=manager)
    work = seq.post(parse_term("(work :fail)"))
    seq.settle()
    assert manager.running() == [parse_term("(finisher 3 :fail)")]
    for step in range(1, 4):
        manager.tick(step * 0.05)
        seq.advance_to(step * 0.05)
    assert work.status == "failed"
    assert work.failure.root().what == "skill (finisher 3 :fail)"
    assert work.failure.root().reason == "finished :fail: it was told to"
    assert seq.memory.holds(parse_term('(why (finisher 3 :fail) "it was told to")'))
    assert manager.running() == []
    play = seq.post(parse_term("(work :succeed)"))
    seq.settle()
    for step in range(4, 7):
        manager.tick(step * 0.05)
        seq.advance_to(step * 0.05)
    assert play.status == "succeeded"


class TellingFinisher(Finisher):
    """A finisher that keeps the reasons it was disabled with."""

    def init(self, context) -> None:
        super().init(context)
        self.reasons: list[str] = []

    def disable(self, reason: str = HALTED) -> None:
        self.reasons.append(reason)


def test_disable_tells_the_skill_the_outcome_it_finished_with_or_that_it_was_halted():
    finisher = TellingFinisher()
    manager = SkillManager([finisher])
    Sequencer(skills=manager)
    early, done = parse_term("(finisher 3 :succeed)"), parse_term("(finisher 1 :fail)")
    manager.enable(early)
    manager.tick(0.05)
    manager.disable(early)  # two ticks short of finishing
    manager.enable(done)
    manager.tick(0.10)
    manager.disable(done)
    assert finisher.reasons == [HALTED, ":fail"], finisher.reasons


def test_halting_a_task_disables_every_skill_its_primitive_enabled():
    program = parse_text("""
        (define-rap (both) (method (primitive (enable (doubler a)) (enable (finisher 99 :succeed))
                                              (wait-for (never)))))
    """).forms
    doubler = Doubler()
    manager = SkillManager([Counter(), doubler, Finisher()])
    seq = Sequencer(program, skills=manager)
    task = seq.post(parse_term("(both)"))
    seq.settle()
    assert sorted(map(str, manager.running())) == sorted(map(str, [parse_term("(doubler a)"),
                                                                  parse_term("(finisher 99 :succeed)")]))
    seq.cancel(task, "enough")
    assert manager.running() == [] and doubler.disabled == 1


def test_the_catalog_that_atlas_check_uses_matches_the_stock_skills():
    from atlas_rap.skills.stock import stock_skills

    manager = SkillManager(stock_skills())
    assert manager.skills() == STOCK_SKILLS
    assert manager.produces() == STOCK_EVENTS


def test_each_stock_skill_class_has_the_interface_it_is_registered_with():
    from atlas_rap.skills.catalog import STOCK, stock_classes

    for entry, skill_class in zip(STOCK, stock_classes(), strict=True):
        assert (skill_class.name, skill_class.params, skill_class.events, skill_class.always_on) == \
            (entry.name, entry.params, entry.events, entry.always_on), entry.code


def test_a_class_registered_under_another_skills_name_is_refused():
    from atlas_rap.skills.catalog import registered

    with pytest.raises(TypeError, match="stock skill move-to is registered as atlas_rap.skills.motion:MoveTo"):
        @registered("move-to")
        class Elsewhere(Skill):
            """Not the class the catalog names."""
