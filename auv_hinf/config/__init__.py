"""Configuration.

The strict TOML schema, the frozen runtime settings, validation messages and warnings,
the preset registry and the generated reference page.
"""
