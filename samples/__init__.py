"""Bundled sample trials and models; installed as `dresslog.samples` so a wheel has them too."""
