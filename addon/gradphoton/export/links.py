"""What feeds an input socket, through reroutes: for the readers that still walk a node tree node
by node (the World, export/world.py; Volume outputs, export/volume.py) until their graphs go
through the core's evaluator as materials' do (export/nodes.py)."""


def linked_from(socket):
    """(node, output socket) feeding an input socket, through reroutes; (None, None) if unlinked."""
    if not socket.is_linked:
        return None, None
    link = socket.links[0]
    node, out = link.from_node, link.from_socket
    while node.bl_idname == 'NodeReroute':
        if not node.inputs[0].is_linked:
            return None, None
        link = node.inputs[0].links[0]
        node, out = link.from_node, link.from_socket
    return node, out
