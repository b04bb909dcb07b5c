"""The site's own Sphinx extension: the ``{kernel}`` role and two rules of the API pages.

**The ``{kernel}`` role: name a private numba kernel, and fail the build when it is gone.**

The kernels (``dcstereo.scanline.dp``, ``dcstereo.divide.bands``, ...) are private, so the
API reference leaves them out and ``{func}`` could not link to them. The algorithm page
still names the functions that implement each step of the paper; this role imports each
name as the site is built and warns (an error under ``-W``) when it does not resolve, so a
renamed or moved kernel breaks ``make docs`` instead of leaving a stale name in the page.

Written ``{kernel}`dcstereo.scanline.dp.scanline_dp``` (or with a title,
``{kernel}`the DP <dcstereo.scanline.dp.scanline_dp>```), it renders as code showing the
name without the package, with the source file and line as a tooltip.

**Re-exported names are documented once**, on the ``dcstereo`` package's page
(``dcstereo.match``, ``dcstereo.MatchParams``, ...): the pages of the modules that define
them leave them out.

**Short names in docstrings resolve when they are unambiguous.** A docstring says
``:class:`DisparityResult``` or ``:data:`dcstereo.params.METHODS``` where the site documents
``dcstereo.DisparityResult`` and ``dcstereo.METHODS``. A reference Sphinx cannot resolve
is given to the one documented object whose full name ends with it, or which is the same
Python object under another name; when there is none, or more than one, the reference
stays unresolved and nitpicky mode fails the build.
"""

import importlib
import inspect
from pathlib import Path

from docutils import nodes
from sphinx.util import logging
from sphinx.util.docutils import SphinxRole
from sphinx.util.nodes import split_explicit_title

logger = logging.getLogger(__name__)


def resolve(name: str):
    """Return the object named by the dotted ``name`` (module path, then attributes)."""
    parts = name.split(".")
    for split in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:split]))
        except ImportError:
            continue
        for attribute in parts[split:]:
            obj = getattr(obj, attribute)  # AttributeError: not found
        return obj
    raise ImportError(name)


def where(obj) -> str:
    """Return ``path:line`` of ``obj``'s source (numba dispatchers: their Python function)."""
    function = getattr(obj, "py_func", obj)
    try:
        path = Path(inspect.getsourcefile(function)).resolve()
        line = inspect.getsourcelines(function)[1]
    except (TypeError, OSError):
        return ""
    for parent in path.parents:
        if parent.name == "src":
            path = path.relative_to(parent.parent)
            break
    return f"{path.as_posix()}:{line}"


class KernelRole(SphinxRole):
    """The ``kernel`` role (see the module docstring)."""

    def run(self):
        """Return the code node of the name, with a warning when it does not resolve."""
        has_title, title, target = split_explicit_title(self.text)
        target = target.strip()
        try:
            obj = resolve(target)
        except (ImportError, AttributeError):
            logger.warning(
                "kernel reference target not found: %s", target, location=self.get_location()
            )
            obj = None
        if not has_title:
            title = target.removeprefix("dcstereo.")
        node = nodes.literal(self.rawtext, title, classes=["xref", "kernel"])
        if obj is not None and not callable(obj):
            logger.warning(
                "kernel reference is not a function: %s", target, location=self.get_location()
            )
        elif obj is not None and (place := where(obj)):
            # HTML: <abbr title="src/dcstereo/kernels/dp.py:219"><code>...</code></abbr>
            node = nodes.abbreviation(self.rawtext, "", node, explanation=place)
        return [node], []


def skip_reexported(app, what, name, obj, skip, options):
    """Leave out of a module's page what ``dcstereo`` re-exports (documented there)."""
    import dcstereo

    if what == "module" and name in dcstereo.__all__:
        try:
            if getattr(dcstereo, name) is obj:
                return True
        except AttributeError:
            pass
    return None


def _same_object(a: str, b: str) -> bool:
    try:
        return resolve(a) is resolve(b)
    except (ImportError, AttributeError):
        return False


def unique_target(app, env, node, contnode):
    """Resolve a Python reference Sphinx missed to its one unambiguous documented object."""
    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"].lstrip("~.")
    domain = env.domains["py"]
    reftype = node["reftype"]
    names = _documented(domain, target)
    if not names and "." in target:
        owner, last = target.rsplit(".", 1)
        names = [n for n in domain.objects if n.endswith("." + last) and _same_object(n, target)]
        if not names:
            # an attribute described in its class's docstring (a dataclass field): the class
            owners = _documented(domain, owner)
            if len(owners) == 1 and last in _fields(owners[0]):
                names, reftype = owners, "class"
    if len(names) != 1:
        return None
    return domain.resolve_xref(env, node["refdoc"], app.builder, reftype, names[0], node, contnode)


def _documented(domain, target: str) -> list[str]:
    """Documented names ending with ``target``; the canonical ones where both match."""
    names = [n for n in domain.objects if n == target or n.endswith("." + target)]
    canonical = [n for n in names if not domain.objects[n].aliased]
    return canonical or names


def _fields(name: str) -> set[str]:
    try:
        cls = resolve(name)
    except (ImportError, AttributeError):
        return set()
    return set(getattr(cls, "__dataclass_fields__", {})) | set(vars(cls))


def setup(app):
    """Register the role and the two rules with Sphinx."""
    app.add_role("kernel", KernelRole())
    app.connect("autodoc-skip-member", skip_reexported)
    app.connect("missing-reference", unique_target)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
