"""Every file path and module that README.md, docs/ and notes/ name exists in the checkout (a moved or deleted file
leaves no stale reference behind)."""
import importlib
import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "notes").glob("*.md"))]
PACKAGES = ("constitutive", "fem", "inference", "cases", "validation")
PATH = re.compile(r"(?<![\w./-])((?:%s|tests|docs|notes|\.ci)/[\w./-]*[\w/])" % "|".join(PACKAGES))
MODULE = re.compile(r"(?<![\w./-])((?:%s)(?:\.\w+)+)" % "|".join(PACKAGES))


def _exists(module: str) -> bool:
    """The longest importable prefix of a dotted name, then attributes for the rest."""
    parts = module.split(".")
    for k in range(len(parts), 0, -1):
        name = ".".join(parts[:k])
        try:
            spec = importlib.util.find_spec(name)
        except ModuleNotFoundError:
            spec = None
        if spec is None:
            continue
        obj = importlib.import_module(name)
        for attr in parts[k:]:
            if not hasattr(obj, attr):
                return False
            obj = getattr(obj, attr)
        return True
    return False


def references():
    for doc in DOCS:
        text = doc.read_text(encoding="utf-8")
        for kind, pattern in (("path", PATH), ("module", MODULE)):
            for m in pattern.finditer(text):
                if text[m.end():m.end() + 1] not in ("*", "{", "<", "["):  # a pattern of names, not one name
                    yield doc, kind, m.group(1).rstrip(".")


@pytest.mark.parametrize("doc", DOCS, ids=lambda d: str(d.relative_to(ROOT)))
def test_every_named_path_and_module_exists(doc):
    stale = set()
    for where, kind, ref in references():
        if where != doc or any(c in ref for c in "*<>{}"):
            continue
        if kind == "path" and not (ROOT / ref).exists():
            stale.add(f"{kind} {ref}")
        if kind == "module" and not (ref.endswith((".py", ".md", ".toml", ".csv", ".json", ".npz", ".png"))
                                     or _exists(ref)):
            stale.add(f"{kind} {ref}")
    assert not stale, f"{doc.relative_to(ROOT)} names what does not exist: {sorted(stale)}"
