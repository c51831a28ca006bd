// Volumetric fog over the froxel grid (app/fog.py, cpu_prep/froxels.py): what its three
// passes share.  Froxel (i, j, k): columns i from the left, rows j from the bottom (GL), depth
// slices k from the near plane; id = (k * H + j) * W + i.
//
// froxel_edges: xs (W+1 pixel edges), ys (H+1), zs (D+1 view depths), us (W+1 NDC), vs (H+1)
layout(std430, binding = B_FROXEL_EDGES) readonly buffer FroxelEdges { float froxel_edges[]; };

uniform uvec3 u_froxels;      // W, H, D
uniform vec2 u_tan;           // tx, ty: view x (y) over depth at NDC 1

float edge_x(uint i) { return froxel_edges[i]; }
float edge_y(uint j) { return froxel_edges[u_froxels.x + 1u + j]; }
float edge_z(uint k) { return froxel_edges[u_froxels.x + u_froxels.y + 2u + k]; }
float edge_u(uint i) { return froxel_edges[u_froxels.x + u_froxels.y + u_froxels.z + 3u + i]; }
float edge_v(uint j) { return froxel_edges[2u * u_froxels.x + u_froxels.y + u_froxels.z + 4u + j]; }

uint froxel_id(uint i, uint j, uint k) { return (k * u_froxels.y + j) * u_froxels.x + i; }
