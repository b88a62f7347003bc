"""The examples of the 3T paper (seed 003) as the language reference gives them (docs/language/), shared by tests."""

ATTACH_AT_SITE = """\
(define-rap (attach-at-site ?thesite)
  (succeed (docked ?thesite))
  (method
    (context (ferrous-hull ?thesite))
    (task-net
      (sequence
        (t1 (approach-site ?thesite))
        (t2 (magnetically-attach ?thesite))
        (wait-for (docked ?thesite)))))
  (method
    (context (not (ferrous-hull ?thesite)))
    (task-net
      (sequence
        (t1 (approach-site ?thesite))
        (t2 (grip-attach ?thesite))
        (wait-for (docked ?thesite))))))
"""
"""The 3T paper's RAP exactly as docs/language/rap.md (define-rap) gives it."""
