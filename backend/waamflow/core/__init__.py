"""Core value types, tolerances and errors shared by every kernel. Imports nothing from the engine."""
