"""InterbotixPointCloudInterface has Interbotix's (humble/jazzy) names and signatures."""
import inspect

from px100_control.client.pointcloud import InterbotixPointCloudInterface
import pytest

REQ = inspect.Parameter.empty
FILTER = ('x_filter_min', 'x_filter_max', 'y_filter_min', 'y_filter_max', 'z_filter_min',
          'z_filter_max', 'voxel_leaf_size', 'plane_max_iter', 'plane_dist_thresh',
          'ror_radius_search', 'ror_min_neighbors', 'cluster_tol', 'cluster_min_size',
          'cluster_max_size')
METHODS = [
    ('__init__', [('self', REQ), ('filter_ns', 'pc_filter'), ('node_inf', None),
                  ('args', None)]),
    ('get_params', [('self', REQ)]),
    ('set_params', [('self', REQ), ('param_dict', REQ)]),
    ('get_filepath', [('self', REQ)]),
    ('enable_pipeline', [('self', REQ), ('enable', REQ)]),
    ('get_cluster_positions', [('self', REQ), ('num_samples', 5), ('period', 0.1),
                               ('ref_frame', None), ('sort_axis', 'y'), ('reverse', False),
                               ('is_parallel', True)]),
    ('load_params', [('self', REQ), ('filepath', None)]),
    ('save_params', [('self', REQ), ('filepath', None)]),
]


@pytest.mark.parametrize('name, params', METHODS, ids=[m[0] for m in METHODS])
def test_method_signature(name, params):
    sig = inspect.signature(getattr(InterbotixPointCloudInterface, name))
    got = [(p.name, p.default) for p in sig.parameters.values()][:len(params)]
    assert got == params


@pytest.mark.parametrize('name', FILTER)
def test_each_filter_parameter_has_a_getter_setter_and_property(name):
    cls = InterbotixPointCloudInterface
    assert isinstance(getattr(cls, name), property)
    assert list(inspect.signature(getattr(cls, f'get_{name}')).parameters) == ['self']
    assert len(inspect.signature(getattr(cls, f'set_{name}')).parameters) == 2
    assert isinstance(cls.params, property)
