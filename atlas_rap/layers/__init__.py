"""The ATLAS multirate executive: physics, skills and the sequencer at their own rates."""
