// The GPU build's shared pieces (app/gpu_build): one invocation an element, 256 a group,
// the groups laid out in 2D when there are more than a dimension holds (65,535 on llvmpipe).
layout(local_size_x = 256) in;

const uint GROUP = 256u;

// The group's place in the 1D sequence of groups of a 2D dispatch.
uint group_index() { return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x; }

uint element_index() { return group_index() * GROUP + gl_LocalInvocationID.x; }
