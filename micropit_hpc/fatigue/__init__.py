"""Fatigue of the material under the rough contact: Dang Van stress (docs/model.md §4.3), the S–N
line and cycle counting (§4.4)."""
