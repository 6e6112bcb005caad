"""``python -m inference.diagnose DIR``: the stable name of ``python -m inference.diagnosis DIR``
(`inference.diagnosis.__main__`)."""
from .diagnosis.__main__ import main

if __name__ == "__main__":
    raise SystemExit(main())
