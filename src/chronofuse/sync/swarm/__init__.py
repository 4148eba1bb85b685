"""Swarm time-keeping over two-way links: neighbour graphs by range, leader election on clock quality, and
the composition of link estimates into each node's time, with holdover and a state per node.

* :mod:`~chronofuse.sync.swarm.graph`: links to the ``k`` nearest neighbours within radio range (a k-d
  tree, so a large swarm does not cost n^2);
* :mod:`~chronofuse.sync.swarm.election`: the best leader by clock quality (IEEE 1588's data-set
  comparison) and the announce timeout that notices a lost one;
* :mod:`~chronofuse.sync.swarm.timekeeping`: each node's correction to the network's time down a tree of
  up links (or with consensus over peer links), holdover on a frozen path when a node loses its way to the
  leader, the network's time kept through a leader loss, and each node's state and uncertainty.
"""
