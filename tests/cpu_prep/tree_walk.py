"""Listing 3 of the tree paper in Python, for the tree tests (test_tree, test_tree_topdown)."""
from cpu_prep import layouts

def traverse(nodes, base, count, depth):
    """Listing 3, in Python: the leaf light ranges hit at `depth`, and nodes visited."""
    i, hit, visited = 0, [], 0
    while i < count:
        n = nodes[base + i]
        visited += 1
        leaf, cnt, skip = (int(v) for v in layouts.unpack_node_bits(n["bits"]))
        if n["min_depth"] <= depth <= n["max_depth"]:
            if leaf:
                hit += list(range(n["first_light"], n["first_light"] + cnt))
            i += 1
        else:
            i += skip
    return hit, visited
