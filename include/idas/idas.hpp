// Umbrella header of idas: everything that needs only the design card's packages.
#pragma once

#include <idas/core/attribute.hpp>
#include <idas/core/concepts.hpp>
#include <idas/core/tuple.hpp>
#include <idas/core/types.hpp>
#include <idas/invariants/link_condition.hpp>
#include <idas/invariants/no_normal_flip.hpp>
#include <idas/invariants/no_self_intersection.hpp>
#include <idas/mesh/backend/corner_table_tri.hpp>
#include <idas/mesh/backend/indexed_tri.hpp>
#include <idas/mesh/topology_report.hpp>
#include <idas/mesh/tri_mesh.hpp>
#include <idas/mesh/validate.hpp>
#include <idas/ops/operation.hpp>
#include <idas/ops/tri_ops.hpp>
