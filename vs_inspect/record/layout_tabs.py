"""A viewer layout (ViewerClient.get_blueprint's dictionary) read and changed: the views it puts
on screen, its tabs' titles, and a tab brought to the front."""

from __future__ import annotations


def _contents(container: dict) -> list[str]:
    """A blueprint container's children ("view/<id>" or "container/<id>"): the viewer gives a
    single child as a string, not a one-element list (a recording whose run accepted no pair)."""
    contents = container.get("contents", [])
    return [contents] if isinstance(contents, str) else list(contents)


def on_screen_views(layout: dict) -> list[str]:
    """View ids (32 hex digits) that a blueprint (ViewerClient.get_blueprint) puts on screen:
    every view under the root container, but only the active tab of a Tabs container."""
    containers = {k.split("/", 2)[2]: v["ContainerBlueprint"] for k, v in layout.items()
                  if k.startswith("/container/") and "ContainerBlueprint" in v}
    inside = {c.split("/", 1)[1] for v in containers.values() for c in _contents(v)}
    roots = [cid for cid in containers if cid not in inside]
    out: list[str] = []

    def walk(item: str) -> None:
        kind, _, ident = item.partition("/")
        if kind == "view":
            out.append(ident.replace("-", ""))
            return
        c = containers.get(ident, {})
        contents = _contents(c)
        if c.get("container_kind") == "Tabs" and contents:
            contents = [c.get("active_tab") or contents[0]]
        for child in contents:
            walk(child)

    for r in roots:
        walk(f"container/{r}")
    return out


def tab_titles(layout: dict) -> list[str]:
    """The titles of the views and containers that are tabs of a Tabs container (what --tab takes)."""
    names = {k.lstrip("/"): str((v.get("ContainerBlueprint") or v.get("ViewBlueprint") or {}).get("display_name", ""))
             for k, v in layout.items() if k.startswith(("/container/", "/view/"))}
    return [names[i] for k, v in layout.items() if v.get("ContainerBlueprint", {}).get("container_kind") == "Tabs"
            for i in _contents(v["ContainerBlueprint"]) if names.get(i)]


def _title_matches(name: str, title: str, suffix: bool) -> bool:
    """A view's or container's title is `title` (a pair container's also without its ✓/✗ mark),
    or ends with it (suffix=True)."""
    names = {name, name[2:] if name[:2] in ("✓ ", "✗ ") else name}
    return any(n.endswith(title) if suffix else n == title for n in names)


def activate_tab(layout: dict, title: str, suffix: bool = False) -> bool:
    """Make the container or view titled `title` (its title as the viewer shows it; or whose title
    ends with it, suffix=True) the active tab of its Tabs container (in place). True when one is
    in front now (also when a view of that title is not in tabs at all, so always on screen);
    False if there is none such."""
    targets = [k.lstrip("/") for k, v in layout.items() if k.startswith(("/container/", "/view/"))
               and _title_matches(str((v.get("ContainerBlueprint") or v.get("ViewBlueprint") or {})
                                      .get("display_name", "")), title, suffix)]
    if not targets:
        return False
    tabs = [(k, v["ContainerBlueprint"]) for k, v in layout.items() if k.startswith("/container/")
            and v.get("ContainerBlueprint", {}).get("container_kind") == "Tabs"]
    for item in targets:
        for _, c in tabs:
            if item in _contents(c):
                c["active_tab"] = item
                return True
    inside = {i for _, c in tabs for i in _contents(c)}
    return any(t.startswith("view/") and t not in inside for t in targets)
