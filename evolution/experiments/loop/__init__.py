"""The evolution loop: a scenario's runs stepped birth by birth, offline or online, to observers."""
