"""What a navigator costs: the energy and traffic ledger of the CML's arrays, with sourced
per-operation constants (:mod:`~cml_edge.costs.ledger`), and the DQN baseline's costs
(:mod:`~cml_edge.costs.dqn`)."""
