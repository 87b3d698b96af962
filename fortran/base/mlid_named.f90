!> Values by name: what the core hands a front end to read back by name
!> (a deck's case, what its run kept; mlid_api_deck's mlid_values), in
!> place of long positional argument lists.  A named_t holds numbers (real
!> or integer, of any shape up to MAXRANK dimensions, kept in Fortran order)
!> and texts, each under its name.
module mlid_named
  use mlid_kinds, only: wp
  implicit none
  private
  public :: named_t, value_t, VALUE_REAL, VALUE_INT, VALUE_TEXT, VALUE_KIND_NAMES, MAXRANK

  integer, parameter :: VALUE_REAL = 1, VALUE_INT = 2, VALUE_TEXT = 3
  !> Their names, one a line in the order of the codes (for the front ends).
  character(len=*), parameter :: VALUE_KIND_NAMES = 'real'//achar(10)//'integer'//achar(10)// &
                                                    'text'//achar(10)
  integer, parameter :: MAXRANK = 3

  type :: value_t
    character(len=:), allocatable :: name
    integer :: kind = 0
    integer :: rank = 0
    integer :: shape(MAXRANK) = 1
    real(wp), allocatable :: r(:)
    integer, allocatable :: i(:)
    character(len=:), allocatable :: t
  end type value_t

  type :: named_t
    type(value_t), allocatable :: v(:)   !< v(1:n) hold values; the rest is room
    integer :: n = 0
  contains
    procedure :: find, put_value, put_real0, put_real1, put_real2, put_int0, put_int1, &
                 put_text, put_logical
    generic :: put => put_real0, put_real1, put_real2, put_int0, put_int1, put_text, put_logical
  end type named_t

contains

  !> Index of name (0: none).
  integer function find(self, name)
    class(named_t), intent(in) :: self
    character(len=*), intent(in) :: name
    integer :: k, m
    find = 0
    m = len_trim(name)
    do k = 1, self%n
      if (self%v(k)%name == name(1:m)) then
        find = k
        return
      end if
    end do
  end function find

  !> Put v under its name, replacing what was there; v is moved in (it is
  !> empty after).  Room doubles as it fills.
  subroutine put_value(self, v)
    class(named_t), intent(inout) :: self
    type(value_t), intent(inout) :: v
    type(value_t), allocatable :: more(:)
    integer :: k
    k = self%find(v%name)
    if (k > 0) then
      call move_value(v, self%v(k))
      return
    end if
    if (.not. allocated(self%v)) allocate (self%v(16))
    if (self%n == size(self%v)) then
      allocate (more(2*self%n))
      do k = 1, self%n
        call move_value(self%v(k), more(k))
      end do
      call move_alloc(more, self%v)
    end if
    self%n = self%n + 1
    call move_value(v, self%v(self%n))
  end subroutine put_value

  !> Moved whole, component by component (no deep copy of the arrays).
  subroutine move_value(from, to)
    type(value_t), intent(inout) :: from
    type(value_t), intent(out) :: to
    call move_alloc(from%name, to%name)
    to%kind = from%kind
    to%rank = from%rank
    to%shape = from%shape
    if (allocated(from%r)) call move_alloc(from%r, to%r)
    if (allocated(from%i)) call move_alloc(from%i, to%i)
    if (allocated(from%t)) call move_alloc(from%t, to%t)
  end subroutine move_value

  function numbers(name, kind, shp) result(v)
    character(len=*), intent(in) :: name
    integer, intent(in) :: kind, shp(:)
    type(value_t) :: v
    v%name = trim(name)
    v%kind = kind
    v%rank = size(shp)
    v%shape = 1
    v%shape(1:size(shp)) = shp
  end function numbers

  subroutine put_real0(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    real(wp), intent(in) :: x
    type(value_t) :: v
    v = numbers(name, VALUE_REAL, [integer ::])
    v%r = [x]
    call self%put_value(v)
  end subroutine put_real0

  subroutine put_real1(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    real(wp), intent(in) :: x(:)
    type(value_t) :: v
    v = numbers(name, VALUE_REAL, shape(x))
    v%r = x
    call self%put_value(v)
  end subroutine put_real1

  subroutine put_real2(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    real(wp), intent(in) :: x(:, :)
    type(value_t) :: v
    v = numbers(name, VALUE_REAL, shape(x))
    v%r = reshape(x, [size(x)])
    call self%put_value(v)
  end subroutine put_real2

  subroutine put_int0(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    integer, intent(in) :: x
    type(value_t) :: v
    v = numbers(name, VALUE_INT, [integer ::])
    v%i = [x]
    call self%put_value(v)
  end subroutine put_int0

  subroutine put_int1(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    integer, intent(in) :: x(:)
    type(value_t) :: v
    v = numbers(name, VALUE_INT, shape(x))
    v%i = x
    call self%put_value(v)
  end subroutine put_int1

  subroutine put_logical(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    logical, intent(in) :: x
    call self%put_int0(name, merge(1, 0, x))
  end subroutine put_logical

  subroutine put_text(self, name, x)
    class(named_t), intent(inout) :: self
    character(len=*), intent(in) :: name
    character(len=*), intent(in) :: x
    type(value_t) :: v
    v%name = trim(name)
    v%kind = VALUE_TEXT
    v%t = x
    call self%put_value(v)
  end subroutine put_text

end module mlid_named
