!> A small, safe expression language for derived channels, the same in
!> both front ends: numbers, channel names (exact, else case-insensitive
!> when unique), + - * / ^, unary minus, parentheses, pi, and the functions
!> sin cos tan asin acos atan atan2 sqrt abs exp log log10 min max tanh
!> step (1 where the argument is > 0, else 0: switches and breakpoints).
!> Nothing is executed but this arithmetic.  An expression is compiled
!> once to postfix code (recursive descent) and evaluated on whole columns.
!> Precedence: ^ (right-associative) above unary minus above * / above + -,
!> so -x^2 = -(x^2) and 2^-1 = 0.5.
module mlid_expr
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_text, only: itoa, to_lower
  implicit none
  private
  public :: expr_t, expr_compile, expr_eval, expr_uses, split_definition, is_name
  public :: OP_NUM, OP_VAR, OP_NEG, OP_ADD, OP_SUB, OP_MUL, OP_DIV, OP_POW, OP_FUN, FUN_ARGS
  public :: F_SIN, F_COS, F_TAN, F_ASIN, F_ACOS, F_ATAN, F_ATAN2, F_SQRT, F_ABS, F_EXP, F_LOG, &
            F_LOG10, F_MIN, F_MAX, F_TANH, F_STEP

  ! Postfix operations.
  integer, parameter :: OP_NUM = 1, OP_VAR = 2, OP_NEG = 3, OP_ADD = 4, OP_SUB = 5, &
                        OP_MUL = 6, OP_DIV = 7, OP_POW = 8, OP_FUN = 9
  ! Functions: their numbers (the arg of OP_FUN), names and argument counts.
  integer, parameter :: F_SIN = 1, F_COS = 2, F_TAN = 3, F_ASIN = 4, F_ACOS = 5, F_ATAN = 6, &
                        F_ATAN2 = 7, F_SQRT = 8, F_ABS = 9, F_EXP = 10, F_LOG = 11, &
                        F_LOG10 = 12, F_MIN = 13, F_MAX = 14, F_TANH = 15, F_STEP = 16
  integer, parameter :: NFUN = 16
  character(len=5), parameter :: FUN_NAME(NFUN) = [character(len=5) :: 'sin', 'cos', 'tan', &
    'asin', 'acos', 'atan', 'atan2', 'sqrt', 'abs', 'exp', 'log', 'log10', 'min', 'max', 'tanh', &
    'step']
  integer, parameter :: FUN_ARGS(NFUN) = [1, 1, 1, 1, 1, 1, 2, 1, 1, 1, 1, 1, 2, 2, 1, 1]
  integer, parameter :: MAXCODE = 512

  !> A compiled expression: postfix code over the channels it was compiled against.
  type :: expr_t
    integer :: n = 0, depth = 0
    integer :: op(MAXCODE) = 0, arg(MAXCODE) = 0
    real(wp) :: num(MAXCODE) = 0.0_wp
  end type expr_t

  !> The parser's state: the text, where it is, and the code so far.
  type :: parser_t
    character(len=:), allocatable :: s
    integer :: p = 1, level = 0, height = 0   !< position, nesting, stack height
    type(expr_t) :: ex
    integer :: status = MLID_OK
    character(len=:), allocatable :: err
    character(len=:), allocatable :: noun   !< what a name stands for: 'channel', 'name'
  end type parser_t

contains

  !> Compile text against the channel names; status and a message naming
  !> the character where it went wrong.  noun: what the names are, for the
  !> message (default 'channel').
  subroutine expr_compile(text, names, ex, status, msg, noun)
    character(len=*), intent(in) :: text
    character(len=*), intent(in) :: names(:)
    type(expr_t), intent(out) :: ex
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    character(len=*), intent(in), optional :: noun
    type(parser_t) :: ps

    ps%s = trim(text)
    ps%err = ''
    ps%noun = 'channel'
    if (present(noun)) ps%noun = noun
    call skip_blanks(ps)
    if (ps%p > len(ps%s)) call fail(ps, 'the expression is empty')
    if (ps%status == MLID_OK) call sum_of(ps, names)
    if (ps%status == MLID_OK .and. ps%p <= len(ps%s)) &
      call fail(ps, 'unexpected '''//ps%s(ps%p:ps%p)//'''')
    status = ps%status
    msg = ps%err
    if (status == MLID_OK) ex = ps%ex
  end subroutine expr_compile

  !> out(i) = the expression on row i of cols(nrow, nchannels).
  subroutine expr_eval(ex, cols, out)
    type(expr_t), intent(in) :: ex
    real(wp), intent(in) :: cols(:, :)
    real(wp), intent(out) :: out(:)
    real(wp) :: st(size(cols, 1), max(ex%depth, 1))
    integer :: k, top

    top = 0
    do k = 1, ex%n
      select case (ex%op(k))
      case (OP_NUM)
        top = top + 1
        st(:, top) = ex%num(k)
      case (OP_VAR)
        top = top + 1
        st(:, top) = cols(:, ex%arg(k))
      case (OP_NEG)
        st(:, top) = -st(:, top)
      case (OP_FUN)
        call apply(ex%arg(k), st, top)
      case default
        call binary(ex%op(k), st(:, top - 1), st(:, top))
        top = top - 1
      end select
    end do
    out = st(:, 1)
  end subroutine expr_eval

  !> The channels an expression reads, each once, in order.
  function expr_uses(ex) result(idx)
    type(expr_t), intent(in) :: ex
    integer, allocatable :: idx(:)
    integer :: k
    allocate (idx(0))
    do k = 1, ex%n
      if (ex%op(k) == OP_VAR) then
        if (.not. any(idx == ex%arg(k))) idx = [idx, ex%arg(k)]
      end if
    end do
  end function expr_uses

  !> 'NAME = rest' -> NAME, rest; NAME must be a name.
  subroutine split_definition(def, name, rhs, status, msg)
    character(len=*), intent(in) :: def
    character(len=*), intent(out) :: name
    character(len=:), allocatable, intent(out) :: rhs
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    integer :: eq

    status = MLID_ERR_INPUT
    name = ''
    rhs = ''
    eq = index(def, '=')
    if (eq == 0) then
      msg = ''''//trim(def)//''' is not of the form NAME = ...'
      return
    end if
    if (.not. is_name(trim(adjustl(def(1:eq - 1))))) then
      msg = ''''//trim(adjustl(def(1:eq - 1)))//''' in '''//trim(def)//''' is not a name'
      return
    end if
    if (len_trim(adjustl(def(1:eq - 1))) > len(name)) then
      msg = 'the name in '''//trim(def)//''' is longer than '//itoa(len(name))//' characters'
      return
    end if
    name = adjustl(def(1:eq - 1))
    rhs = trim(adjustl(def(eq + 1:)))
    status = MLID_OK
    msg = ''
  end subroutine split_definition

  ! ---- parser: sum_of > product_of > signed > power_of > primary ----

  recursive subroutine sum_of(ps, names)
    type(parser_t), intent(inout) :: ps
    character(len=*), intent(in) :: names(:)
    character :: c
    call product_of(ps, names)
    do while (ps%status == MLID_OK .and. next_is(ps, '+-'))
      c = ps%s(ps%p:ps%p)
      call advance(ps)
      call product_of(ps, names)
      if (c == '+') call emit(ps, OP_ADD, 0, 0.0_wp, -1)
      if (c == '-') call emit(ps, OP_SUB, 0, 0.0_wp, -1)
    end do
  end subroutine sum_of

  recursive subroutine product_of(ps, names)
    type(parser_t), intent(inout) :: ps
    character(len=*), intent(in) :: names(:)
    character :: c
    call signed(ps, names)
    do while (ps%status == MLID_OK .and. next_is(ps, '*/'))
      c = ps%s(ps%p:ps%p)
      call advance(ps)
      call signed(ps, names)
      if (c == '*') call emit(ps, OP_MUL, 0, 0.0_wp, -1)
      if (c == '/') call emit(ps, OP_DIV, 0, 0.0_wp, -1)
    end do
  end subroutine product_of

  recursive subroutine signed(ps, names)
    type(parser_t), intent(inout) :: ps
    character(len=*), intent(in) :: names(:)
    character :: c
    if (next_is(ps, '+-')) then
      c = ps%s(ps%p:ps%p)
      call advance(ps)
      call signed(ps, names)
      if (c == '-') call emit(ps, OP_NEG, 0, 0.0_wp, 0)
    else
      call power_of(ps, names)
    end if
  end subroutine signed

  recursive subroutine power_of(ps, names)
    type(parser_t), intent(inout) :: ps
    character(len=*), intent(in) :: names(:)
    call primary(ps, names)
    if (ps%status == MLID_OK .and. next_is(ps, '^')) then
      call advance(ps)
      call signed(ps, names)      ! right-associative; 2^-1 allowed
      call emit(ps, OP_POW, 0, 0.0_wp, -1)
    end if
  end subroutine power_of

  !> A number, a parenthesised expression, a function call, pi or a channel.
  recursive subroutine primary(ps, names)
    type(parser_t), intent(inout) :: ps
    character(len=*), intent(in) :: names(:)
    character(len=:), allocatable :: word
    integer :: at

    if (ps%status /= MLID_OK) return
    if (ps%p > len(ps%s)) then
      call fail(ps, 'a value is missing at the end')
      return
    end if
    at = ps%p
    if (next_is(ps, '(')) then
      ps%level = ps%level + 1
      if (ps%level > 50) call fail(ps, 'parentheses nested more than 50 deep')
      call advance(ps)
      call sum_of(ps, names)
      call expect(ps, ')')
      ps%level = ps%level - 1
    else if (scan(ps%s(ps%p:ps%p), '0123456789.') == 1) then
      call number(ps)
    else if (is_name(ps%s(ps%p:ps%p))) then
      word = take_word(ps)
      call skip_blanks(ps)
      if (next_is(ps, '(')) then
        call call_of(ps, names, word, at)
      else
        call channel(ps, names, word, at)
      end if
    else
      call fail(ps, 'unexpected '''//ps%s(ps%p:ps%p)//'''')
    end if
  end subroutine primary

  !> A function call: its arguments, each an expression, then the function.
  recursive subroutine call_of(ps, names, word, at)
    type(parser_t), intent(inout) :: ps
    character(len=*), intent(in) :: names(:), word
    integer, intent(in) :: at
    integer :: f, k

    f = findloc(FUN_NAME == to_lower(word), .true., 1)
    if (f == 0) then
      ps%p = at
      call fail(ps, 'unknown function '//word//' (functions: sin cos tan asin acos atan '// &
                'atan2 sqrt abs exp log log10 min max tanh step)')
      return
    end if
    call advance(ps)
    do k = 1, FUN_ARGS(f)
      if (k > 1 .and. next_is(ps, ')')) call fail(ps, word//' takes '//itoa(FUN_ARGS(f))// &
                                                  ' arguments')
      if (k > 1) call expect(ps, ',')
      call sum_of(ps, names)
    end do
    if (ps%status == MLID_OK .and. .not. next_is(ps, ')')) then
      call fail(ps, word//' takes '//itoa(FUN_ARGS(f))//' argument(s)')
      return
    end if
    call expect(ps, ')')
    call emit(ps, OP_FUN, f, 0.0_wp, 1 - FUN_ARGS(f))
  end subroutine call_of

  !> A channel by name (exact, else case-insensitive when unique), or pi.
  subroutine channel(ps, names, word, at)
    type(parser_t), intent(inout) :: ps
    character(len=*), intent(in) :: names(:), word
    integer, intent(in) :: at
    logical :: same(size(names))

    same = names == word
    if (count(same) == 0) same = to_lower(names) == to_lower(word)
    if (count(same) == 1) then
      call emit(ps, OP_VAR, findloc(same, .true., 1), 0.0_wp, 1)
    else if (count(same) == 0 .and. to_lower(word) == 'pi') then
      call emit(ps, OP_NUM, 0, acos(-1.0_wp), 1)
    else
      ps%p = at
      if (count(same) == 0) call fail(ps, 'no '//ps%noun//' named '//word)
      if (count(same) > 1) call fail(ps, itoa(count(same))//' '//ps%noun//'s are named '//word)
    end if
  end subroutine channel

  !> A number: digits, a point, an exponent (E or D).
  subroutine number(ps)
    type(parser_t), intent(inout) :: ps
    integer :: e, ios
    real(wp) :: v
    e = ps%p
    do while (e <= len(ps%s))
      if (scan(ps%s(e:e), '0123456789.') == 1) then
        e = e + 1
      else if (scan(ps%s(e:e), 'eEdD') == 1 .and. e < len(ps%s)) then
        e = e + 1
        if (scan(ps%s(e:e), '+-') == 1) e = e + 1
      else
        exit
      end if
    end do
    read (ps%s(ps%p:e - 1), *, iostat=ios) v
    if (ios /= 0 .or. index(ps%s(ps%p:e - 1), '.', back=.true.) /= index(ps%s(ps%p:e - 1), '.')) then
      call fail(ps, ''''//ps%s(ps%p:e - 1)//''' is not a number')
      return
    end if
    ps%p = e
    call skip_blanks(ps)
    call emit(ps, OP_NUM, 0, v, 1)
  end subroutine number

  ! ---- parser helpers ----

  subroutine emit(ps, op, arg, num, push)
    type(parser_t), intent(inout) :: ps
    integer, intent(in) :: op, arg, push
    real(wp), intent(in) :: num
    if (ps%status /= MLID_OK) return
    if (ps%ex%n == MAXCODE) then
      call fail(ps, 'the expression is too long (at most '//itoa(MAXCODE)//' operations)')
      return
    end if
    ps%ex%n = ps%ex%n + 1
    ps%ex%op(ps%ex%n) = op
    ps%ex%arg(ps%ex%n) = arg
    ps%ex%num(ps%ex%n) = num
    ps%height = ps%height + push
    ps%ex%depth = max(ps%ex%depth, ps%height)
  end subroutine emit

  logical function next_is(ps, chars)
    type(parser_t), intent(in) :: ps
    character(len=*), intent(in) :: chars
    next_is = .false.
    if (ps%p <= len(ps%s)) next_is = scan(ps%s(ps%p:ps%p), chars) == 1
  end function next_is

  subroutine expect(ps, c)
    type(parser_t), intent(inout) :: ps
    character, intent(in) :: c
    if (ps%status /= MLID_OK) return
    if (next_is(ps, c)) then
      call advance(ps)
    else if (ps%p > len(ps%s)) then
      call fail(ps, ''''//c//''' is missing at the end')
    else
      call fail(ps, 'expected '''//c//''', found '''//ps%s(ps%p:ps%p)//'''')
    end if
  end subroutine expect

  subroutine advance(ps)
    type(parser_t), intent(inout) :: ps
    ps%p = ps%p + 1
    call skip_blanks(ps)
  end subroutine advance

  subroutine skip_blanks(ps)
    type(parser_t), intent(inout) :: ps
    do while (ps%p <= len(ps%s))
      if (ps%s(ps%p:ps%p) /= ' ' .and. ps%s(ps%p:ps%p) /= achar(9)) exit
      ps%p = ps%p + 1
    end do
  end subroutine skip_blanks

  function take_word(ps) result(word)
    type(parser_t), intent(inout) :: ps
    character(len=:), allocatable :: word
    integer :: e
    e = ps%p
    do while (e < len(ps%s))
      if (.not. is_name(ps%s(ps%p:e + 1))) exit
      e = e + 1
    end do
    word = ps%s(ps%p:e)
    ps%p = e + 1
  end function take_word

  !> A name: a letter or _, then letters, digits, _ and '.'.
  pure logical function is_name(s)
    character(len=*), intent(in) :: s
    character(len=*), parameter :: first = 'abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ_'
    is_name = .false.
    if (len(s) == 0) return
    is_name = scan(s(1:1), first) == 1 .and. verify(s, first//'0123456789.') == 0
  end function is_name

  subroutine fail(ps, why)
    type(parser_t), intent(inout) :: ps
    character(len=*), intent(in) :: why
    if (ps%status /= MLID_OK) return
    ps%status = MLID_ERR_INPUT
    ps%err = excerpt(ps%s, ps%p)//' at character '//itoa(min(ps%p, len(ps%s) + 1))//': '//why
  end subroutine fail

  !> The text quoted, or for a long one the 60 characters around position p,
  !> so that the message stays one readable line.
  function excerpt(s, p) result(q)
    character(len=*), intent(in) :: s
    integer, intent(in) :: p
    character(len=:), allocatable :: q
    integer :: a, b
    if (len(s) <= 60) then
      q = ''''//s//''''
      return
    end if
    a = max(1, min(p, len(s)) - 30)
    b = min(len(s), a + 59)
    q = ''''//trim(merge('...', '   ', a > 1))//s(a:b)//trim(merge('...', '   ', b < len(s)))//''''
  end function excerpt

  ! ---- evaluation ----

  subroutine binary(op, a, b)
    integer, intent(in) :: op
    real(wp), intent(inout) :: a(:)
    real(wp), intent(in) :: b(:)
    select case (op)
    case (OP_ADD)
      a = a + b
    case (OP_SUB)
      a = a - b
    case (OP_MUL)
      a = a*b
    case (OP_DIV)
      a = a/b
    case (OP_POW)
      a = a**b
    end select
  end subroutine binary

  subroutine apply(f, st, top)
    integer, intent(in) :: f
    real(wp), intent(inout) :: st(:, :)
    integer, intent(inout) :: top
    associate (x => st(:, top))
      select case (trim(FUN_NAME(f)))
      case ('sin')
        x = sin(x)
      case ('cos')
        x = cos(x)
      case ('tan')
        x = tan(x)
      case ('asin')
        x = asin(x)
      case ('acos')
        x = acos(x)
      case ('atan')
        x = atan(x)
      case ('sqrt')
        x = sqrt(x)
      case ('abs')
        x = abs(x)
      case ('exp')
        x = exp(x)
      case ('log')
        x = log(x)
      case ('log10')
        x = log10(x)
      case ('tanh')
        x = tanh(x)
      case ('step')
        x = merge(1.0_wp, 0.0_wp, x > 0.0_wp)
      case ('atan2')
        st(:, top - 1) = atan2(st(:, top - 1), x)
      case ('min')
        st(:, top - 1) = min(st(:, top - 1), x)
      case ('max')
        st(:, top - 1) = max(st(:, top - 1), x)
      end select
    end associate
    top = top + 1 - FUN_ARGS(f)
  end subroutine apply

end module mlid_expr
