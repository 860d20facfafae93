"""mbs.base: what every layer may use and that uses none of them: files written atomically (atomic.py) and where
the rebuildable caches live (cachedir.py). The layers above (language -> compiler -> runtime -> mbs) import it;
it imports nothing of theirs, so no layer reaches up to mbs/ for a file write."""
