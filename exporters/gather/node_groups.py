"""Node trees read through their node groups, as Cycles compiles them: a link from a
group node continues at the socket its Group Output receives inside the group, and a
link from a Group Input continues at the group node's socket outside. The walkers
(material.py, pattern.py, world.py) see the nodes inside groups as if they were in the
material's own tree.

A node inside groups is a `Node` that carries the group nodes it was reached through
(`path`): one group used twice is two sets of nodes, each reading its own group
node's inputs. Its `name` is prefixed by those group nodes' names (`Group/Math`), so
warnings and the pattern graph's node names tell the instances apart. Everything else
(bl_idname, operation, image, ...) is the Blender node's own."""
from __future__ import annotations


class Node:
    def __init__(self, node, path=()):
        self._node = node
        self.path = tuple(path)

    def __getattr__(self, name):
        return getattr(self._node, name)

    @property
    def name(self):
        return "/".join([g.name for g in self.path] + [self._node.name])

    @property
    def inputs(self):
        return _Sockets(self, self._node.inputs)

    @property
    def outputs(self):
        return _Sockets(self, self._node.outputs)

    def _key(self):
        return tuple(g.as_pointer() for g in self.path) + (self._node.as_pointer(),)

    def __eq__(self, other):
        return isinstance(other, Node) and self._key() == other._key()

    def __hash__(self):
        return hash(self._key())


class _Sockets:
    """A node's inputs or outputs, indexed by position or name, as Blender's are."""

    def __init__(self, node, sockets):
        self._node, self._sockets = node, sockets

    def __getitem__(self, key):
        return Socket(self._sockets[key], self._node)

    def __iter__(self):
        return (Socket(s, self._node) for s in self._sockets)

    def __len__(self):
        return len(self._sockets)

    def get(self, key, default=None):
        found = self._sockets.get(key)
        return default if found is None else Socket(found, self._node)


class Socket:
    def __init__(self, socket, node):
        self._socket = socket
        self.node = node

    def __getattr__(self, name):
        return getattr(self._socket, name)

    @property
    def is_linked(self):
        return link(self) is not None

    @property
    def default_value(self):
        """The value it takes when nothing feeds it: through a Group Input, the group
        node's socket's."""
        return _unlinked(self)[0].default_value

    def __eq__(self, other):
        return isinstance(other, Socket) and self.node == other.node and \
            self._socket.as_pointer() == other._socket.as_pointer()

    def __hash__(self):
        return hash((self.node, self._socket.as_pointer()))


class Link:
    def __init__(self, from_socket, from_node):
        self.from_socket, self.from_node = from_socket, from_node


def wrap(socket) -> Socket:
    """A socket of the material's (or world's) own tree."""
    return socket if isinstance(socket, Socket) else Socket(socket, Node(socket.node))


def link(socket):
    """The Link feeding `socket` (a Socket, or a socket of the top tree) through
    reroutes and groups, or None when nothing does: unlinked, a muted or invalid link,
    a group with no tree or no Group Output, or a group input left unlinked outside."""
    return _unlinked(wrap(socket))[1]


def _unlinked(socket):
    """(the bpy socket whose own value applies when nothing feeds `socket`, the Link
    feeding it or None)."""
    s, path = socket._socket, socket.node.path
    while s.is_linked:
        found = s.links[0]
        if not found.is_valid or found.is_muted:
            return s, None
        node = found.from_node
        if node.bl_idname == "NodeReroute":
            s = node.inputs[0]
        elif node.bl_idname == "ShaderNodeGroup":
            inner = _group_output(node, found.from_socket.identifier)
            if inner is None:
                return s, Link(Socket(found.from_socket, Node(node, path)), Node(node, path))
            s, path = inner, path + (node,)
        elif node.bl_idname == "NodeGroupInput" and path:
            group = path[-1]
            s = next(i for i in group.inputs if i.identifier == found.from_socket.identifier)
            path = path[:-1]
        else:
            owner = Node(node, path)
            return s, Link(Socket(found.from_socket, owner), owner)
    return s, None


def _group_output(group, identifier):
    """The input of `group`'s active Group Output that its output `identifier` gives,
    or None (no tree, or no Group Output: the group node is then seen as itself)."""
    tree = group.node_tree
    if tree is None:
        return None
    outputs = [n for n in tree.nodes if n.bl_idname == "NodeGroupOutput"]
    active = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    if active is None:
        return None
    return next((i for i in active.inputs if i.identifier == identifier), None)


def all_nodes(tree, seen=None):
    """The nodes of `tree` and of the node groups inside it, each group's tree once."""
    seen = set() if seen is None else seen
    if tree is None or tree.as_pointer() in seen:
        return
    seen.add(tree.as_pointer())
    for node in tree.nodes:
        yield node
        if node.bl_idname == "ShaderNodeGroup":
            yield from all_nodes(node.node_tree, seen)
