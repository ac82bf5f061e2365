"""Contact models: penalty forces (``penalty.py``) and constraint rows (``rows.py``)."""
