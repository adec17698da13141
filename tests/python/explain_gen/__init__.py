"""Independent generator of measured-like joint data for `naic explain` (Python + Pinocchio;
shares no code with crates/naic_explain/src/generate.rs). See generate.py."""
from .generate import EFFECTS, Case, generate  # noqa: F401
