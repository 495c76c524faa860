"""Concrete dropout (Gal, Hron and Kendall 2017) and the dropout + fully connected head of Bayesian VMC."""

from __future__ import annotations

import math

import torch
from torch import Tensor, nn


class ConcreteDropout(nn.Module):
    """Dropout with a learned rate and a relaxed (concrete) Bernoulli mask.

    p = sigmoid(p_logit); z = sigmoid((log p - log(1-p) + log u - log(1-u)) / temperature), u ~ U(0, 1)
    per element; x -> x * (1 - z) / (1 - p). Whether the mask is drawn is passed explicitly on every
    call (`stochastic`), never read from `self.training`: LeRobot's `select_action` and the in-training
    eval (upstream issue 3668) call `policy.eval()`.

    Args:
        in_features: K, the size of the input the mask applies to (scales the dropout regulariser).
        init_p: initial dropout probability.
        temperature: temperature of the relaxed Bernoulli.
        eps: numerical guard inside the logarithms.
    """

    def __init__(self, in_features: int, init_p: float = 0.1, temperature: float = 0.1, eps: float = 1e-7):
        super().__init__()
        self.in_features = in_features
        self.temperature = temperature
        self.eps = eps
        self.p_logit = nn.Parameter(torch.tensor(math.log(init_p) - math.log(1.0 - init_p)))

    @property
    def p(self) -> Tensor:
        """The dropout probability, a scalar tensor."""
        return torch.sigmoid(self.p_logit)

    def forward(self, x: Tensor, stochastic: bool, noise: Tensor | None = None) -> Tensor:
        """Apply the relaxed mask.

        Args:
            x: (..., K) input.
            stochastic: draw a mask; when False the layer is the identity (the expectation).
            noise: optional (..., K) uniform noise u to use instead of `torch.rand_like(x)`.

        Returns:
            (..., K) masked and rescaled input.
        """
        if not stochastic:
            return x
        u = torch.rand_like(x, memory_format=torch.contiguous_format) if noise is None else noise
        # log p - log(1 - p) is p_logit exactly; logit(u, eps) = log u - log(1 - u) with u clamped to
        # [eps, 1 - eps]. The keep mask 1 - z = sigmoid(-(p_logit + logit(u)) / temperature).
        # In place on the fresh logit tensor (fewer allocations; autograd-safe: logit saves its input).
        keep = torch.logit(u, self.eps).add_(self.p_logit).mul_(-1.0 / self.temperature).sigmoid_()
        return x * keep / (1.0 - self.p)

    def regularization(self, weight: Tensor, weight_reg: float, dropout_reg: float) -> Tensor:
        """weight_reg * sum(W^2) / (1 - p) + dropout_reg * K * (p log p + (1 - p) log(1 - p)).

        Args:
            weight: the weight matrix of the layer this dropout feeds.
            weight_reg: l^2 / N.
            dropout_reg: 2 / N.
        """
        p = self.p
        weight_term = weight_reg * weight.square().sum() / (1.0 - p)
        neg_entropy = p * torch.log(p + self.eps) + (1.0 - p) * torch.log(1.0 - p + self.eps)
        return weight_term + dropout_reg * self.in_features * neg_entropy


class ConcreteDropoutHead(nn.Module):
    """[concrete dropout -> linear -> ReLU] x num_layers, applied to the LSTM embedding (the paper's Fig. 2).

    Args:
        in_dim: size of the LSTM embedding e_t.
        hidden_dim: width of each fully connected layer.
        num_layers: number of dropout + fully connected pairs.
        init_p: initial dropout probability of every layer.
        temperature: temperature of the relaxed masks.
        weight_reg: l^2 / N.
        dropout_reg: 2 / N.
    """

    def __init__(
        self,
        in_dim: int,
        hidden_dim: int,
        num_layers: int,
        init_p: float,
        temperature: float,
        weight_reg: float,
        dropout_reg: float,
    ):
        super().__init__()
        dims = [in_dim] + [hidden_dim] * num_layers
        self.dropouts = nn.ModuleList(ConcreteDropout(d, init_p, temperature) for d in dims[:-1])
        self.linears = nn.ModuleList(nn.Linear(a, b) for a, b in zip(dims[:-1], dims[1:], strict=True))
        self.weight_reg = weight_reg
        self.dropout_reg = dropout_reg
        self.out_dim = hidden_dim

    def noise_shapes(self, *leading: int) -> list[tuple[int, ...]]:
        """Shapes of the uniform noise each dropout layer draws for an input of shape (*leading, in_dim)."""
        return [(*leading, d.in_features) for d in self.dropouts]

    def forward(self, x: Tensor, stochastic: bool, noise: list[Tensor] | None = None) -> Tensor:
        """(..., in_dim) -> (..., hidden_dim); masks drawn iff `stochastic` (from `noise` if given)."""
        for i, (dropout, linear) in enumerate(zip(self.dropouts, self.linears, strict=True)):
            x = torch.relu(linear(dropout(x, stochastic, None if noise is None else noise[i])))
        return x

    def regularization(self) -> Tensor:
        """Sum of the concrete dropout regularisers of all layers (a scalar to add to the loss)."""
        terms = [
            d.regularization(lin.weight, self.weight_reg, self.dropout_reg)
            for d, lin in zip(self.dropouts, self.linears, strict=True)
        ]
        return torch.stack(terms).sum()

    def dropout_probabilities(self) -> list[float]:
        """Current dropout probability of each layer."""
        return [d.p.item() for d in self.dropouts]
