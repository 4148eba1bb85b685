"""Physical truth models (SPEC section 2): oscillators and their noise."""
