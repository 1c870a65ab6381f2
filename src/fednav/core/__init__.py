"""The bottom layer: SI units and their edge conversions, the Earth model, attitude
algebra, small compiled kernels, fednav's error base class, atomic file writes and the
YAML/pydantic loader every configuration file goes through.  Imports nothing else of
fednav."""
