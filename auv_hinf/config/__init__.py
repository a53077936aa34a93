"""Configuration.

The strict TOML schema, validation messages, runtime tables, FormationConfig and the
preset registry.
"""
