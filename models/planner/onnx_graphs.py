"""The two graphs the onnx engine exports from a ``minilm-encdec`` planner: the encoder, and one decoder step.

Why these two and not ``generate``'s forward: in a planner call most of the time went to transformers'
per-step machinery rather than arithmetic. Each of ~20 beam-search steps multiplies 4 rows by 256-wide
matrices, yet it took ~6 ms: cache objects, mask building, the 384 -> 256 projection of the encoder states
redone for every beam at every step, and the cross-attention keys and values (the same for every beam)
gathered again after every beam reorder. Here the encoder graph ends with the cross-attention keys and
values of every decoder layer, computed once per input for one row that all beams share, and the step
graph takes the self-attention cache as an input and returns it one token longer.

The step's operations and their order are those of ``transformers``' ``BertLMHeadModel`` in eval mode
(embeddings: word + token type 0, then + position, LayerNorm; per layer: self-attention over the cache,
cross-attention, GELU feed-forward, each closed by a residual LayerNorm; the prediction head's transform,
then the tied output matrix), so its logits agree with it to float rounding.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import torch
import torch.nn.functional as F
from torch import nn
from transformers import BertLMHeadModel, BertModel, EncoderDecoderModel, PreTrainedModel


def graphs_support(model: PreTrainedModel) -> bool:
    """True for an ``EncoderDecoderModel`` of a BERT encoder and a BERT decoder with cross-attention and
    GELU (the ``minilm-encdec`` recipe's); other seq2seq models decode with ``generate``."""
    if not isinstance(model, EncoderDecoderModel):
        return False
    if not isinstance(model.encoder, BertModel) or not isinstance(model.decoder, BertLMHeadModel):
        return False
    config = model.decoder.config
    return bool(config.add_cross_attention) and config.hidden_act == "gelu"


@dataclass(frozen=True)
class _Norm:
    weight: torch.Tensor
    bias: torch.Tensor
    eps: float

    @classmethod
    def of(cls, module: nn.LayerNorm) -> _Norm:
        return cls(module.weight.detach(), module.bias.detach(), module.eps)

    def __call__(self, x: torch.Tensor) -> torch.Tensor:
        return F.layer_norm(x, self.weight.shape, self.weight, self.bias, self.eps)


@dataclass(frozen=True)
class _Linear:
    weight: torch.Tensor  # [out, in]
    bias: torch.Tensor  # [out]

    @classmethod
    def of(cls, *modules: nn.Linear) -> _Linear:
        """One linear map, or several with the same input stacked into one matrix (one product, not three)."""
        return cls(
            torch.cat([m.weight.detach() for m in modules]), torch.cat([m.bias.detach() for m in modules])
        )

    def __call__(self, x: torch.Tensor) -> torch.Tensor:
        return F.linear(x, self.weight, self.bias)


@dataclass(frozen=True)
class _Layer:
    self_qkv: _Linear  # hidden -> 3 x hidden; the query rows carry the attention scale
    self_out: _Linear
    self_norm: _Norm
    cross_query: _Linear  # carries the attention scale
    cross_key_value: _Linear  # hidden -> 2 x hidden, in the encoder graph
    cross_out: _Linear
    cross_norm: _Norm
    ffn_in: _Linear
    ffn_out: _Linear
    ffn_norm: _Norm


def _scaled(linear: _Linear, rows: int, scale: float) -> _Linear:
    """``linear`` with its first ``rows`` outputs multiplied by ``scale``: the attention's 1/sqrt(head dim)
    applied to the query once, in the weights (exact for 64-wide heads, whose scale is a power of two)."""
    factor = torch.ones(linear.weight.shape[0])
    factor[:rows] = scale
    return _Linear(linear.weight * factor[:, None], linear.bias * factor)


def _layers(decoder: BertLMHeadModel) -> tuple[_Layer, ...]:
    layers: Any = decoder.bert.encoder.layer  # BertLayer modules (transformers types them loosely)
    hidden = int(decoder.config.hidden_size)
    scale = (hidden // int(decoder.config.num_attention_heads)) ** -0.5
    return tuple(
        _Layer(
            self_qkv=_scaled(
                _Linear.of(layer.attention.self.query, layer.attention.self.key, layer.attention.self.value),
                hidden,
                scale,
            ),
            self_out=_Linear.of(layer.attention.output.dense),
            self_norm=_Norm.of(layer.attention.output.LayerNorm),
            cross_query=_scaled(_Linear.of(layer.crossattention.self.query), hidden, scale),
            cross_key_value=_Linear.of(layer.crossattention.self.key, layer.crossattention.self.value),
            cross_out=_Linear.of(layer.crossattention.output.dense),
            cross_norm=_Norm.of(layer.crossattention.output.LayerNorm),
            ffn_in=_Linear.of(layer.intermediate.dense),
            ffn_out=_Linear.of(layer.output.dense),
            ffn_norm=_Norm.of(layer.output.LayerNorm),
        )
        for layer in layers
    )


def _attend(query: torch.Tensor, keys_t: torch.Tensor, values: torch.Tensor) -> torch.Tensor:
    """Attention of one (scaled) query per beam: [B, heads, 1, d] against keys transposed
    [B or 1, heads, d, T] and values [B or 1, heads, T, d] -> [B, heads * d]."""
    B, heads, _, d = query.shape
    weights = torch.softmax(torch.matmul(query, keys_t), dim=-1)  # [B, heads, 1, T]
    return torch.matmul(weights, values).reshape(B, heads * d)


@dataclass(frozen=True)
class DecoderShape:
    """Sizes the engine needs to build the graphs' inputs."""

    layers: int
    heads: int
    head_dim: int
    vocab_size: int
    max_positions: int


def decoder_shape(model: EncoderDecoderModel) -> DecoderShape:
    config = model.decoder.config
    heads = int(config.num_attention_heads)
    return DecoderShape(
        layers=int(config.num_hidden_layers),
        heads=heads,
        head_dim=int(config.hidden_size) // heads,
        vocab_size=int(config.vocab_size),
        max_positions=int(config.max_position_embeddings),
    )


class EncoderGraph(nn.Module):
    """input ids int64 [1, S] (one input, no padding) -> for each decoder layer, its cross-attention keys
    transposed, float32 [1, heads, head dim, S], and values [1, heads, S, head dim]."""

    def __init__(self, model: EncoderDecoderModel) -> None:
        super().__init__()
        self.encoder = model.get_encoder()
        self.projection = getattr(model, "enc_to_dec_proj", None)  # absent when the widths match
        assert isinstance(model.decoder, BertLMHeadModel), "checked by graphs_support"
        self.layers = _layers(model.decoder)
        self.shape = decoder_shape(model)

    def forward(self, input_ids: torch.Tensor) -> tuple[torch.Tensor, ...]:
        states = self.encoder(
            input_ids=input_ids, attention_mask=torch.ones_like(input_ids)
        ).last_hidden_state
        if self.projection is not None:
            states = self.projection(states)  # [1, S, decoder hidden]
        _, S, _ = states.shape
        out = []
        for layer in self.layers:
            keys_values = layer.cross_key_value(states[0]).view(S, 2, self.shape.heads, self.shape.head_dim)
            out.append(keys_values[:, 0].permute(1, 2, 0).unsqueeze(0))  # [1, heads, d, S]
            out.append(keys_values[:, 1].transpose(0, 1).unsqueeze(0))  # [1, heads, S, d]
        return tuple(out)


class DecoderStepGraph(nn.Module):
    """One token per beam through the decoder.

    tokens int64 [B], the last token of each beam, at position int64 [1]; then per layer: the keys and
    values of the tokens before, float32 [B, heads, T, head dim] each (T = position), and the layer's two
    outputs of ``EncoderGraph`` -> log-probabilities of the next token float32 [B, V], then per layer the
    keys and values one token longer, [B, heads, T + 1, head dim].
    """

    def __init__(self, model: EncoderDecoderModel) -> None:
        super().__init__()
        decoder = model.decoder
        assert isinstance(decoder, BertLMHeadModel), "checked by graphs_support"
        self.shape = decoder_shape(model)
        embeddings = decoder.bert.embeddings
        word = embeddings.word_embeddings.weight.detach()  # [V, hidden]
        self.word_and_type = word + embeddings.token_type_embeddings.weight.detach()[0]  # BERT's segment 0
        self.position = embeddings.position_embeddings.weight.detach()  # [max positions, hidden]
        self.embedding_norm = _Norm.of(embeddings.LayerNorm)
        self.layers = _layers(decoder)
        head = decoder.cls.predictions
        self.head_transform = _Linear.of(head.transform.dense)
        self.head_norm = _Norm.of(head.transform.LayerNorm)
        self.output = _Linear.of(head.decoder)  # [V, hidden], tied to the word embeddings

    def forward(
        self, tokens: torch.Tensor, position: torch.Tensor, *caches: torch.Tensor
    ) -> tuple[torch.Tensor, ...]:
        (B,) = tokens.shape
        heads, d = self.shape.heads, self.shape.head_dim
        hidden = heads * d
        x = self.embedding_norm(self.word_and_type[tokens] + self.position[position])  # [B, hidden]
        present = []
        for i, layer in enumerate(self.layers):
            past_keys, past_values, cross_keys_t, cross_values = caches[4 * i : 4 * i + 4]
            query, key, value = layer.self_qkv(x).split(hidden, dim=1)  # [B, hidden] each
            keys = torch.cat([past_keys, key.view(B, heads, 1, d)], dim=2)  # [B, heads, T + 1, d]
            values = torch.cat([past_values, value.view(B, heads, 1, d)], dim=2)
            present += [keys, values]
            attended = _attend(query.view(B, heads, 1, d), keys.transpose(2, 3), values)
            x = layer.self_norm(layer.self_out(attended) + x)
            query = layer.cross_query(x).view(B, heads, 1, d)
            attended = _attend(query, cross_keys_t, cross_values)  # the encoder's rows, shared by the beams
            x = layer.cross_norm(layer.cross_out(attended) + x)
            x = layer.ffn_norm(layer.ffn_out(F.gelu(layer.ffn_in(x))) + x)
        logits = self.output(self.head_norm(F.gelu(self.head_transform(x))))  # [B, V]
        return (torch.log_softmax(logits, dim=-1), *present)
