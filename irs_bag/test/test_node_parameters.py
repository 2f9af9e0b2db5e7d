"""The recorder's parameter asker (``irs_bag.node_parameters``) on a fake node: who is asked,
what is written, and what a node that does not answer gets; and the records read back.
"""
import json

from rcl_interfaces.msg import ParameterType, ParameterValue
from rclpy.parameter import parameter_value_to_python

from irs_bag.node_parameters import (ATTEMPTS, RECORD, TIMEOUT_S, ParameterAsker,
                                     node_parameters_from_records)
from irs_bag.run_info import run_info_from_metadata


class Future:
    """An rclpy future the test completes by setting ``value``."""

    def __init__(self):
        self.value = None

    def done(self):
        return self.value is not None

    def result(self):
        return self.value


class Client:
    """A service client: its service name, whether the service is up, the calls made."""

    def __init__(self, service, ready):
        self.service, self.ready, self.futures = service, ready, []

    def service_is_ready(self):
        return self.ready

    def call_async(self, request):
        self.futures.append((request, Future()))
        return self.futures[-1][1]


class Logger:
    """The warnings logged."""

    def __init__(self):
        self.lines = []

    def warning(self, text):
        self.lines.append(text)


class Owner:
    """The recorder as the asker sees it: its name, the graph's nodes, clients, a logger."""

    def __init__(self, nodes, ready=True):
        self.nodes, self.ready = nodes, ready
        self.clients, self.destroyed, self.logger = [], [], Logger()

    def get_name(self):
        return 'recorder'

    def get_namespace(self):
        return '/'

    def get_node_names_and_namespaces(self):
        return self.nodes

    def create_client(self, srv_type, service):
        self.clients.append(Client(service, self.ready))
        return self.clients[-1]

    def destroy_client(self, client):
        self.destroyed.append(client)

    def get_logger(self):
        return self.logger


def _list_answer(names):
    from rcl_interfaces.srv import ListParameters
    response = ListParameters.Response()
    response.result.names = names
    return response


def _get_answer(values):
    from rcl_interfaces.srv import GetParameters
    response = GetParameters.Response()
    response.values = values
    return response


def test_each_other_node_is_asked_once_and_its_answer_written():
    owner = Owner([('recorder', '/'), ('lateral_controller', '/'), ('rig', '/lab')])
    written = []
    asker = ParameterAsker(owner, lambda node, params: written.append((node, params)),
                           parameter_value_to_python)
    asker.poll()
    services = sorted(c.service for c in owner.clients)
    assert services == ['/lab/rig/list_parameters', '/lateral_controller/list_parameters']
    ctrl = next(c for c in owner.clients if c.service.startswith('/lateral'))
    ctrl.futures[0][1].value = _list_answer(['mode', 'kp', 'gains'])
    asker.poll()
    get = owner.clients[-1]
    assert get.service == '/lateral_controller/get_parameters'
    assert list(get.futures[0][0].names) == ['mode', 'kp', 'gains']
    get.futures[0][1].value = _get_answer([
        ParameterValue(type=ParameterType.PARAMETER_STRING, string_value='pi'),
        ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=5.0),
        ParameterValue(type=ParameterType.PARAMETER_DOUBLE_ARRAY, double_array_value=[1.0, 2.0])])
    asker.poll()
    assert written == [('/lateral_controller', {'mode': 'pi', 'kp': 5.0, 'gains': [1.0, 2.0]})]
    assert ctrl in owner.destroyed and get in owner.destroyed
    n_clients = len(owner.clients)
    asker.poll()                       # asked once: no new client for it
    assert len(owner.clients) == n_clients
    assert '/lateral_controller' in asker.done and '/lab/rig' in asker.asking


def test_a_node_that_does_not_answer_is_asked_again_then_left_out():
    now = [0.0]
    owner = Owner([('mute', '/')])
    asker = ParameterAsker(owner, lambda *a: None, parameter_value_to_python,
                           clock=lambda: now[0])
    for attempt in range(ATTEMPTS):
        asker.poll()                   # a new list_parameters request
        assert len(owner.clients) == attempt + 1 and len(owner.clients[-1].futures) == 1
        now[0] += TIMEOUT_S + 0.1
        asker.poll()                   # timed out: its client destroyed
        assert owner.clients[-1] in owner.destroyed
    assert '/mute' in asker.done and not asker.asking
    assert owner.logger.lines == [f'/mute: its parameters are not in the bag (did not answer '
                                  f'within {TIMEOUT_S:g} s, {ATTEMPTS} times)']


def test_a_service_not_yet_discovered_is_waited_for():
    owner = Owner([('slow', '/')], ready=False)
    asker = ParameterAsker(owner, lambda *a: None, parameter_value_to_python)
    asker.poll()
    asker.poll()
    assert len(owner.clients) == 1 and owner.clients[0].futures == []
    owner.clients[0].ready = True
    asker.poll()
    assert len(owner.clients[0].futures) == 1
    asker.close()
    assert owner.clients[0] in owner.destroyed and not asker.asking


def test_the_records_read_back_as_node_parameters_and_name_the_controller():
    records = [('irs_experiment', {'x': '1'}),
               (RECORD, {'node': '/lateral_controller', 'parameters': json.dumps(
                   {'mode': 'mrc', 'include_actuator': False})}),
               (RECORD, {'node': '/lab/vehicle_sim', 'parameters': json.dumps(
                   {'car.length': 0.5, 'arm.l1': 0.7})}),
               (RECORD, {'node': '/broken', 'parameters': 'not json'}),
               (RECORD, {'node': '/listed', 'parameters': '[1, 2]'})]
    params = node_parameters_from_records(records)
    assert params == {'lateral_controller': {'mode': 'mrc', 'include_actuator': False},
                      'vehicle_sim': {'car.length': 0.5, 'arm.l1': 0.7}}
    info = run_info_from_metadata('run', None, params)
    assert info.controller == 'MRC without actuator model'
    assert info.car_length == 0.5 and info.geometry.l1 == 0.7
    # an experiment's own node parameters come first
    exp = {'node_parameters': json.dumps({'lateral_controller': {'mode': 'pi', 'kp': 1,
                                                                 'ki': 2}})}
    assert run_info_from_metadata('run', exp, params).controller == 'PI (kp 1, ki 2)'
    assert run_info_from_metadata('run', None, {}).controller == 'controller unknown'
