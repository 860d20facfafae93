"""The .mbs language front end: source text -> AST -> validated data model (see frontend.py)."""
