"""Controllers: one module per controller family, registered by name (see ``controllers/base.py``)."""
