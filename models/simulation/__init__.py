"""Scene simulation: only the effects a scene names, its loop, plant, friction, verdicts."""
