"""Links bind and reach the host their URL names, so that nothing assumes one machine: a
``tcp-listen://`` node on 127.0.0.2 answers there and only there, two nodes share a port on two
addresses, IPv6 literals and host names work, and a host that cannot be used is a LinkError that
names the URL. Every address here is a loopback one (127.0.0.0/8, ::1) or one no machine holds
(192.0.2.0/24, TEST-NET-1), so nothing is reachable from outside."""

from __future__ import annotations

import socket
from contextlib import ExitStack

import pytest

from hexmigrate.errors import LinkError, LinkUrlError
from hexmigrate.links import open_link
from hexmigrate.links.remote_server import RemoteCanServer
from hexmigrate.links.tcp import TcpListenLink

RECEIVE = 5.0


def listening(stack: ExitStack, url: str) -> TcpListenLink:
    link = stack.enter_context(open_link(url))
    assert isinstance(link, TcpListenLink)
    return link


def ipv6_loopback() -> bool:
    """Whether this machine has ::1 (a container may have no IPv6 at all)."""
    try:
        with socket.socket(socket.AF_INET6) as probe:
            probe.bind(("::1", 0))
    except OSError:
        return False
    return True


def test_a_listener_on_127_0_0_2_says_so_and_does_not_answer_on_127_0_0_1() -> None:
    with ExitStack() as stack:
        node = listening(stack, "tcp-listen://127.0.0.2:0")
        assert node.bound_url == f"tcp-listen://127.0.0.2:{node.port}"
        assert node.connect_url == f"socket://127.0.0.2:{node.port}"
        with pytest.raises(ConnectionRefusedError):
            socket.create_connection(("127.0.0.1", node.port), timeout=RECEIVE).close()
        with pytest.raises(LinkError, match=rf"^cannot open socket://127\.0\.0\.1:{node.port}: "):
            open_link(f"socket://127.0.0.1:{node.port}")
        host = stack.enter_context(open_link(node.connect_url))
        host.send(b"PING")
        assert node.receive(RECEIVE) == b"PING"
        node.send(b"PONG")
        assert host.receive(RECEIVE) == b"PONG"
        assert node.connections == 1


def test_two_nodes_listen_on_one_port_of_two_addresses() -> None:
    """Only two listeners that each bind their own address can share a port."""
    with ExitStack() as stack:
        first = listening(stack, "tcp-listen://127.0.0.2:0")
        second = listening(stack, f"tcp-listen://127.0.0.3:{first.port}")
        assert second.connect_url == f"socket://127.0.0.3:{first.port}"
        for node, word in ((first, b"TWO"), (second, b"THREE")):
            host = stack.enter_context(open_link(node.connect_url))
            host.send(word)
            assert node.receive(RECEIVE) == word
        assert (first.connections, second.connections) == (1, 1)
        assert first.receive(0.1) is None and second.receive(0.1) is None


@pytest.mark.skipif(not ipv6_loopback(), reason="no IPv6 loopback address on this machine")
def test_an_ipv6_literal_is_written_in_brackets() -> None:
    with ExitStack() as stack:
        node = listening(stack, "tcp-listen://[::1]:0")
        assert node.bound_url == f"tcp-listen://[::1]:{node.port}"
        assert node.connect_url == f"socket://[::1]:{node.port}"
        host = stack.enter_context(open_link(node.connect_url))
        host.send(b"\x01six")
        assert node.receive(RECEIVE) == b"\x01six"


def test_a_host_name_is_kept_in_the_urls() -> None:
    with ExitStack() as stack:
        node = listening(stack, "tcp-listen://localhost:0")
        assert node.connect_url == f"socket://localhost:{node.port}"
        host = stack.enter_context(open_link(node.connect_url))
        host.send(b"NAMED")
        assert node.receive(RECEIVE) == b"NAMED"


IPV4 = "host: expected an IPv4 address such as 127.0.0.1, got"
NAME = "host: expected an IPv4 or IPv6 address or a host name, got"


@pytest.mark.parametrize(
    ("url", "problem"),
    [
        ("tcp-listen://256.1.1.1:0", f"{IPV4} '256.1.1.1'"),
        ("tcp-listen://1.2.3:0", f"{IPV4} '1.2.3'"),
        ("tcp-listen://::1:0", "host: expected an IPv6 address in brackets such as [::1], got "
         "'::1'"),
        ("tcp-listen://[::1:0", "expected an IPv6 address between brackets: Invalid IPv6 URL"),
        ("tcp-listen://a_b:0", f"{NAME} 'a_b'"),
        ("tcp-listen://-a.b:0", f"{NAME} '-a.b'"),
        ("tcp-listen://127.0.0.1", "expected HOST:PORT after tcp-listen://, got '127.0.0.1'"),
        ("socket://a b:7000", f"{NAME} 'a b'"),
        ("can://remote/a_b:7000/x", f"{NAME} 'a_b'"),
    ],
)  # fmt: skip
def test_a_malformed_host_is_refused_before_anything_opens(url: str, problem: str) -> None:
    with pytest.raises(LinkUrlError) as caught:
        open_link(url)
    assert str(caught.value).startswith(f"bad link URL {url!r}: {problem}; the form is ")


@pytest.mark.parametrize(
    ("url", "cause"),
    [
        ("tcp-listen://192.0.2.1:0", "cannot listen on 192.0.2.1 port 0: Cannot assign requested"),
        ("tcp-listen://no-such-host.invalid:0", "cannot resolve 'no-such-host.invalid': "),
    ],
)
def test_a_host_that_cannot_be_listened_on_is_a_link_error_naming_the_url(
    url: str, cause: str
) -> None:
    with pytest.raises(LinkError) as caught:
        open_link(url)
    assert not isinstance(caught.value, LinkUrlError)
    assert str(caught.value).startswith(f"cannot open {url}: {cause}")


def test_a_remote_can_server_serves_the_address_it_is_given() -> None:
    with RemoteCanServer("hosts", host="127.0.0.2") as server:
        assert server.url().startswith(f"can://remote/127.0.0.2:{server.port}/hosts?")
        with pytest.raises(ConnectionRefusedError):
            socket.create_connection(("127.0.0.1", server.port), timeout=RECEIVE).close()
        with open_link(server.url()) as host, open_link(server.url(role="node")) as node:
            host.send(b"\x01over the server on 127.0.0.2")
            assert node.receive(RECEIVE) == b"\x01over the server on 127.0.0.2"


@pytest.mark.parametrize(
    ("host", "problem"),
    [
        ("::1", "expected an IPv4 address or a host name (python-can-remote's server listens "
         "on IPv4 only), got '::1'"),
        ("a b", "expected an IPv4 or IPv6 address or a host name, got 'a b'"),
    ],
)  # fmt: skip
def test_a_remote_can_server_refuses_a_host_it_cannot_serve(host: str, problem: str) -> None:
    with pytest.raises(LinkError) as caught:
        RemoteCanServer("hosts", host=host)
    assert str(caught.value) == f"cannot serve CAN channel 'hosts': host: {problem}"


def test_a_remote_can_server_on_an_address_not_of_this_machine_does_not_start() -> None:
    server = RemoteCanServer("hosts", host="192.0.2.1")
    with pytest.raises(
        LinkError, match=r"^cannot start a python-can-remote server on '192\.0\.2\.1'"
    ):
        server.start()
    assert server.port == 0
