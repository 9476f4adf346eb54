/* The extension cadpipe.core._kernels: every kernel file, compiled as one unit.
 *
 * Each file holds one idea and ends in its table of entry points; this file
 * includes them in the pipeline's order and publishes every table as one module
 * (cadpipe.core.kernels checks it and hands it to the Python side).
 */
#include "native.h"

#include "points.c"
#include "transform.c"
#include "convex.c"
#include "topology.c"
#include "kinematics.c"
#include "motion.c"
#include "capsules.c"
#include "fixture.c"
#include "boxtree.c"
#include "winding.c"
#include "intersect.c"
#include "clearance.c"
#include "hierarchy.c"
#include "chain_mesh.c"
#include "triangle_tree.c"
#include "packed.c"
#include "narrow.c"
#include "funnel.c"
#include "normals.c"
#include "threemf.c"
#include "meshfiles.c"

/* one table a line */
static PyMethodDef *tables[] = {
    points_methods,
    transform_methods,
    convex_methods,
    topology_methods,
    kinematics_methods,
    motion_methods,
    capsules_methods,
    fixture_methods,
    boxtree_methods,
    winding_methods,
    intersect_methods,
    clearance_methods,
    hierarchy_methods,
    chain_mesh_methods,
    triangle_tree_methods,
    packed_methods,
    narrow_methods,
    funnel_methods,
    normals_methods,
    threemf_methods,
    meshfiles_methods,
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "cadpipe.core._kernels",
                                    "cadpipe's compiled kernels (see csrc/native.h).", -1,
                                    NULL};

PyMODINIT_FUNC PyInit__kernels(void)
{
    import_array();
    size_t count = 0;
    for (size_t t = 0; t < sizeof tables / sizeof *tables; t++)
        for (PyMethodDef *m = tables[t]; m->ml_name; m++)
            count++;
    static PyMethodDef *all = NULL;
    if (!all) {
        all = PyMem_Calloc(count + 1, sizeof *all);   /* lives as long as the process */
        if (!all)
            return PyErr_NoMemory();
        size_t at = 0;
        for (size_t t = 0; t < sizeof tables / sizeof *tables; t++)
            for (PyMethodDef *m = tables[t]; m->ml_name; m++)
                all[at++] = *m;
    }
    module.m_methods = all;
    PyObject *m = PyModule_Create(&module);
    if (m && (PyModule_AddStringConstant(m, "SOURCE_HASH", CP_SOURCE_HASH) < 0 ||
              PyModule_AddType(m, &packed_type) < 0)) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
