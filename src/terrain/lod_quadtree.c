/* quadtree mode (seed 000, SPEC T2-T6a): restricted quadtree selected
 * breadth-first over a flag array that is never cleared; fans skip the edge
 * midpoint toward a coarser neighbour. No GL. */
#include "lod_internal.h"

hz_result hz__lod_select_quadtree(hz_lod *lod, const hz_camera *cam, const hz_lod_params *params,
                                  hz_index_list *out, hz_node_list *leaves, hz_node_list *culled,
                                  hz_lod_stats *stats)
{
    const hz_lod_params p = *params;
    const uint32_t n = lod->size;
    hz_lod_stats st = {0};
    vec4 planes[6];
    hz_camera_frustum(cam, planes);
    const split_rule rule = split_rule_make(cam, &p);
    const float margin = frustum_margin(cam);

    qnode *cur = lod->q[0], *next = lod->q[1];
    size_t ncur = 1;
    cur[0] = (qnode){(n - 1) / 2, (n - 1) / 2};
    for (uint32_t l = 0; l < lod->levels && ncur > 0; l++) {
        const uint32_t s = half_of(lod, l);
        const bool can_split = l + 1 < lod->levels;
        size_t nnext = 0;
        /* Worst case this level emits 8 triangles per node. */
        if (list_reserve((void **)&out->data, &out->cap, out->count + ncur * 24, sizeof(uint32_t)))
            return HZ_ERR_MEMORY;
        for (size_t k = 0; k < ncur; k++) {
            const uint32_t x = cur[k].x, z = cur[k].z;
            const size_t idx = node_index(lod, l, x, z);
            st.nodes_visited++;
            if (!p.no_cull) {
                vec3 box[2];
                box_of(lod, idx, x, z, s, box);
                if (box_outside((const vec3 *)box, (const vec4 *)planes, margin)) {
                    lod->flags[idx] = ST_CULLED;
                    st.nodes_culled++;
                    if (push_node(culled, x, z, s, l))
                        return HZ_ERR_MEMORY;
                    continue;
                }
            }
            uint8_t nb[4];
            bool blocked = false;
            for (int dir = 0; dir < 4; dir++) {
                nb[dir] = neighbour_of(lod, l, x, z, s, dir);
                blocked |= nb[dir] == NB_ABSENT;
            }
            bool split = false;
            if (can_split) {
                split = split_rule_test(lod, &rule, x, z, s, idx);
                if (split && blocked) {
                    st.restricted++;
                    split = false;
                }
            }
            if (split) {
                uint8_t f = ST_SPLIT;
                for (int dir = 0; dir < 4; dir++)
                    if (nb[dir] == NB_DONTCARE)
                        f |= (uint8_t)(1u << (DC_SHIFT + dir));
                lod->flags[idx] = f;
                const uint32_t h = s / 2;
                next[nnext++] = (qnode){x - h, z - h};
                next[nnext++] = (qnode){x + h, z - h};
                next[nnext++] = (qnode){x - h, z + h};
                next[nnext++] = (qnode){x + h, z + h};
            } else {
                lod->flags[idx] = ST_LEAF;
                uint32_t tris = hz__emit_fan(out->data + out->count, n, x, z, s, nb);
                out->count += 3 * tris;
                st.triangles += tris;
                st.leaves++;
                if (l > st.max_level)
                    st.max_level = l;
                if (push_node(leaves, x, z, s, l))
                    return HZ_ERR_MEMORY;
            }
        }
        qnode *t = cur;
        cur = next;
        next = t;
        ncur = nnext;
    }
    *stats = st;
    return HZ_OK;
}

