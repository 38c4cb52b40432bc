"""Decision engines: how Phase 3 ticks the behaviour tree of every agent."""
