; A robot carries parcels between rooms joined by doors: the PDDL example of
; the docs (docs/how-to/plan.md), `atlas plan --pddl` on this domain and
; rooms-problem.pddl. STRIPS with typing and negative preconditions.
(define (domain rooms)
  (:requirements :strips :typing :negative-preconditions)
  (:types room parcel)
  (:predicates (at-robot ?r - room) (at ?p - parcel ?r - room) (door ?a - room ?b - room)
               (holding ?p - parcel) (hand-full))
  (:action move
    :parameters (?from - room ?to - room)
    :precondition (and (at-robot ?from) (door ?from ?to))
    :effect (and (at-robot ?to) (not (at-robot ?from))))
  (:action pick
    :parameters (?p - parcel ?r - room)
    :precondition (and (at-robot ?r) (at ?p ?r) (not (hand-full)))
    :effect (and (holding ?p) (hand-full) (not (at ?p ?r))))
  (:action drop
    :parameters (?p - parcel ?r - room)
    :precondition (and (at-robot ?r) (holding ?p))
    :effect (and (at ?p ?r) (not (holding ?p)) (not (hand-full)))))
