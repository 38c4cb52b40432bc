"""Motion models and their control systems, as pure functions over swarm arrays."""
