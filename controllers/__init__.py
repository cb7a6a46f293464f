"""Python controllers the co-simulation master runs: see ``cosim.controller.Controller`` for the interface."""
