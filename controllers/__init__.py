"""Python controllers the co-simulation master runs: see ``controllers.base.Controller`` for the interface."""
