"""Generated inputs for the benchmarks: a large RAP library, many facts.

Deterministic (seeded) so that every run measures the same text.
"""

from __future__ import annotations

import random

_RAP = """\
;; RAP {i}: generated for the reader benchmark
(define-rap (deliver-{i} ?item ?place)
  (succeed (delivered ?item ?place))
  (constraints (and (robot-ok) (not (broken ?item))))
  (timeout {timeout})
  (priority {priority})
  (retries 4)
  (method by-hand-{i}
    (context (and (at ?item ?from) (reachable ?from ?place) (< (weight ?item) {weight})))
    (task-net
      (sequence
        (t1 (navigate-to ?from))
        (t2 (pick-up ?item) (wait-for (holding robot ?item) :succeed) (wait-for (dropped ?item) :fail))
        (parallel
          (t3 (navigate-to ?place))
          (t4 (track-object ?item) (until-end t3)))
        (t5 (put-down ?item ?place))
        (assert (delivered ?item ?place)))))
  (method with-cart-{i}
    (context (and (cart ?c) (at ?c ?where)))
    (primitive
      (enable (move-to {x} {y}) (avoid-obstacles))
      (wait-for (at robot ?place) :succeed :timeout 30.5)
      (wait-for (blocked robot) :fail)
      (disable :above))))

(define-memory-rule unique-{i}
  (on (at ?thing ?new))
  (when (and (at ?thing ?old) (/= ?old ?new)))
  (retract (at ?thing ?old)))

(operator carry-{i}
  :purpose (at ?item ?place)
  :agent ?robot
  :arguments ((?w (get-value ?item weight)))
  :preconditions ((holding ?robot ?item) (path ?here ?place))
  :constraints ((can-lift ?robot ?w))
  :plot (sequence (go ?robot ?place) (drop ?robot ?item))
  :effects ((at ?item ?place) (not (holding ?robot ?item)))
  :duration {duration})

"""


def rap_library(min_bytes: int = 5 * 1024 * 1024, seed: int = 1) -> str:
    """A RAP/AP library of at least ``min_bytes`` bytes of valid source text."""
    rng = random.Random(seed)
    parts = []
    size = 0
    i = 0
    while size < min_bytes:
        text = _RAP.format(i=i, timeout=rng.randint(10, 600), priority=rng.randint(0, 9),
                           weight=rng.randint(1, 50), x=round(rng.uniform(-20, 20), 2),
                           y=round(rng.uniform(-20, 20), 2), duration=rng.randint(1, 30))
        parts.append(text)
        size += len(text)
        i += 1
    return "".join(parts)
