"""The API reference, generated from ``chronofuse.api`` at build time (``.. chronofuse-api::``).

Every public name of :mod:`chronofuse.api` (its ``__all__``) gets an autodoc entry under the section of the
package that defines it; a name no section claims fails the build, so a new public name cannot be left out.
A cross-reference to ``chronofuse.api.NAME`` that does not resolve is a warning (the build runs with -W), so
the capability pages cannot point at a name that is not documented.
"""

from __future__ import annotations

import importlib

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.pycode import ModuleAnalyzer
from sphinx.util.docutils import SphinxDirective

#: Section title -> the defining modules' prefixes, in the order data flows.
SECTIONS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("Swarm sync", ("chronofuse.models.kinematics", "chronofuse.models.link", "chronofuse.sync",
                    "chronofuse.experiments.swarm")),
    ("Truth models", ("chronofuse.models",)),
    ("GNSS and positioning", ("chronofuse.gnss", "chronofuse.positioning")),
    ("Data in: records, recordings, field logs, sources", ("chronofuse.io", "chronofuse.record", "chronofuse.epochs")),
    ("Monitor", ("chronofuse.monitor",)),
    ("Stability analysis and masks", ("chronofuse.analysis",)),
    ("Estimation", ("chronofuse.estimation",)),
    ("Integrity", ("chronofuse.integrity",)),
    ("Discipline (GNSSDO)", ("chronofuse.discipline",)),
    ("Experiments and scenarios", ("chronofuse.experiments",)),
    ("Errors", ("chronofuse.validation",)),
)
ORDER = ("Truth models", "GNSS and positioning", "Data in: records, recordings, field logs, sources", "Monitor",
         "Stability analysis and masks", "Estimation", "Integrity", "Discipline (GNSSDO)",
         "Experiments and scenarios", "Swarm sync", "Errors")


def _where(name: str, api) -> tuple[str, str]:
    entry = api._EXPORTS[name]
    return (entry, name) if isinstance(entry, str) else entry


def _section(module: str) -> str:
    for title, prefixes in SECTIONS:
        if any(module == p or module.startswith(p + ".") for p in prefixes):
            return title
    raise ValueError(f"chronofuse.api: no section of docs/_ext/apiref.py claims module {module!r}")


def _data_doc(module: str, attr: str, value) -> list[str]:
    """The ``#:`` comment documenting ``attr`` in ``module``, else what the value is."""
    docs = ModuleAnalyzer.for_module(module).find_attr_docs()
    found = docs.get(("", attr))
    if found:
        return [line for line in found if line is not None]
    if isinstance(value, dict):
        keys = ", ".join(f"``{k}``" for k in list(value)[:12])
        more = ", ..." if len(value) > 12 else ""
        return [f"A ``dict`` of {len(value)} entries: {keys}{more} (defined in ``{module}``)."]
    if isinstance(value, (tuple, list, frozenset, set)):
        items = ", ".join(f"``{v}``" for v in list(value)[:12])
        return [f"A ``{type(value).__name__}`` of {len(value)}: {items} (defined in ``{module}``)."]
    return [f"Defined in ``{module}``."]


class ApiReference(SphinxDirective):
    has_content = False

    def run(self):
        api = importlib.import_module("chronofuse.api")
        groups: dict[str, list[str]] = {title: [] for title in ORDER}
        for name in api.__all__:
            module, _ = _where(name, api)
            groups[_section(module)].append(name)
        lines = StringList()

        def add(text: list[str], source: str = "chronofuse.api"):
            for i, line in enumerate(text):
                lines.append(line, source, i)

        for title in ORDER:
            names = groups[title]
            if not names:
                continue
            add([title, "-" * len(title), ""])
            for name in names:
                module, attr = _where(name, api)
                value = getattr(api, name)
                target = f"chronofuse.api.{name}"
                if isinstance(value, type):
                    add([f".. autoclass:: {target}", "   :members:", ""], target)
                elif callable(value):
                    add([f".. autofunction:: {target}", ""], target)
                else:
                    add([f".. py:data:: {target}", ""] + [f"   {line}" for line in _data_doc(module, attr, value)] + [""],
                        target)
        container = nodes.section()
        container.document = self.state.document
        self.state.nested_parse(lines, self.content_offset, container,
                                match_titles=True)
        return container.children


def _missing(app, env, node, contnode):
    target = node.get("reftarget", "")
    if node.get("refdomain") == "py" and target.startswith("chronofuse.api."):
        from sphinx.util import logging

        logging.getLogger(__name__).warning("unresolved reference to %s (not in the API reference)", target,
                                            location=node)
    return None


def setup(app):
    app.add_directive("chronofuse-api", ApiReference)
    app.connect("missing-reference", _missing)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
