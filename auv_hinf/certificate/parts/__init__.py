"""The certificate parts: each adapts one concept package to the part protocol."""
