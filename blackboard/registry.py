"""Token type registry: token type names ↔ frozen pydantic attribute models."""

from __future__ import annotations

import importlib
from typing import Any, Callable, TypeVar

from pydantic import BaseModel, ValidationError

from blackboard.errors import InvalidTokenError, UnknownTypeError
from wire import token_types

__all__ = ["TypeRegistry", "default_registry", "token_type"]

M = TypeVar("M", bound=type[BaseModel])


class TypeRegistry:
    """Map type names to pydantic models; validate raw attribute dicts against them.

    Registries are plain objects: inject one into a node or client, or use `default_registry`.
    """

    def __init__(self) -> None:
        self._models: dict[str, type[BaseModel]] = {}
        self._names: dict[type[BaseModel], str] = {}

    def register(self, name: str, model: type[BaseModel]) -> type[BaseModel]:
        """Register `model` under `name`; re-registering the same pair is a no-op."""
        if not isinstance(name, str) or not name or "/" in name or "*" in name or "$" in name:
            raise ValueError(f"type name {name!r} must be a non-empty string without '/', '*', '$'")
        if not (isinstance(model, type) and issubclass(model, BaseModel)):
            raise TypeError(f"{model!r} is not a pydantic model class")
        old = self._models.get(name)
        if old is not None and old is not model and old.__qualname__ != model.__qualname__:
            raise ValueError(f"type name {name!r} is already registered to {old.__qualname__}")
        self._models[name] = model
        self._names[model] = name
        return model

    def names(self) -> list[str]:
        """Return the registered type names, sorted."""
        return sorted(self._models)

    def __contains__(self, name: object) -> bool:
        return name in self._models

    def model(self, name: str) -> type[BaseModel]:
        """Return the model registered under `name`; raise UnknownTypeError."""
        try:
            return self._models[name]
        except (KeyError, TypeError):
            raise UnknownTypeError(f"unknown token type {name!r}; registered: {', '.join(self.names()) or '(none)'}") from None

    def name_of(self, model: BaseModel | type[BaseModel]) -> str:
        """Return the registered type name of a model instance or class; raise UnknownTypeError."""
        cls = model if isinstance(model, type) else type(model)
        for klass in cls.__mro__:
            name = self._names.get(klass)  # type: ignore[arg-type]
            if name is not None:
                return name
        raise UnknownTypeError(f"model {cls.__qualname__} is not registered as a token type")

    def validate_raw(self, name: str, attrs: Any) -> dict:
        """Validate raw attributes against type `name`; return the normalised JSON-able dict."""
        model = self.model(name)
        if not isinstance(attrs, dict):
            raise InvalidTokenError(f"attrs of a {name!r} token must be an object, got {type(attrs).__name__}")
        try:
            inst = model.__pydantic_validator__.validate_python(attrs)
        except ValidationError as exc:
            raise InvalidTokenError(f"invalid {name!r} attrs: {_short(exc)}") from None
        except Exception as exc:  # noqa: BLE001 - a model's own validator may raise anything
            raise InvalidTokenError(f"invalid {name!r} attrs: {type(exc).__name__}: {exc}"[:500]) from None
        try:
            return model.__pydantic_serializer__.to_python(inst, mode="json")
        except Exception as exc:  # noqa: BLE001 - e.g. a value JSON cannot carry
            raise InvalidTokenError(f"{name!r} attrs cannot be serialised: {exc}"[:500]) from None

    def decode(self, name: str, attrs: dict) -> BaseModel:
        """Return the model instance of type `name` built from stored (already valid) attributes."""
        model = self.model(name)
        try:
            return model.__pydantic_validator__.validate_python(attrs)
        except ValidationError as exc:
            raise InvalidTokenError(f"stored {name!r} attrs do not validate here: {_short(exc)}") from None

    def decoder(self, name: str) -> Callable[[dict], BaseModel]:
        """Return `decode` for type `name` with its model looked up once (for many tokens of one type); raise UnknownTypeError."""
        validate = self.model(name).__pydantic_validator__.validate_python
        decode = self.decode

        def decode_one(attrs: dict) -> BaseModel:
            try:
                return validate(attrs)
            except ValidationError:
                return decode(name, attrs)  # raises the typed error

        return decode_one

    def import_module(self, module: str) -> None:
        """Import a module whose @token_type declarations register into this registry (or the default)."""
        try:
            importlib.import_module(module)
        except ImportError as exc:
            raise ImportError(f"cannot import token types module {module!r}: {exc}") from exc


def _short(exc: ValidationError) -> str:
    parts = []
    for e in exc.errors()[:5]:
        loc = ".".join(str(p) for p in e.get("loc", ())) or "(root)"
        parts.append(f"{loc}: {e.get('msg')}")
    return "; ".join(parts)


#: The registry `@token_type` registers into unless told otherwise; it also takes every type declared in
#: `wire.token_types` (the modules' vocabulary declares there, so importing it does not load the blackboard).
default_registry = TypeRegistry()
token_types.follow(default_registry.register)


def token_type(name: str, *, registry: TypeRegistry | None = None) -> Callable[[M], M]:
    """Register the decorated frozen pydantic model as token type `name` (in `default_registry` by default)."""

    def deco(model: M) -> M:
        (registry if registry is not None else default_registry).register(name, model)
        return model

    return deco
